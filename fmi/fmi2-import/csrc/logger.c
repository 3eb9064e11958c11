/*
 * fmi2CallbackLogger for the import crate (fmi2-import).
 *
 * The logger is C-variadic (printf-style), which stable Rust can call but not
 * define, so this shim formats the message and forwards the finished text to a
 * Rust sink. The sink is not linked by name: the component environment points at
 * a Rust #[repr(C)] struct whose first field is the sink, which avoids link-order
 * trouble between this static library and the Rust crate.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void (*fmi2_import_sink)(void *env, const char *instance_name, int status,
                                 const char *category, const char *message);

/* Layout of the Rust `LogEnv` prefix (src/logger.rs). */
struct fmi2_import_env {
    fmi2_import_sink sink;
};

/* Messages up to this size are formatted without touching the heap. */
#define FMI2_IMPORT_STACK_BUFFER 512

void fmi2_import_logger(void *env, const char *instance_name, int status,
                        const char *category, const char *message, ...) {
    struct fmi2_import_env *e = (struct fmi2_import_env *)env;
    char stack_buf[FMI2_IMPORT_STACK_BUFFER];
    va_list args;
    va_list again;
    int needed;

    if (e == NULL || e->sink == NULL) {
        /* No master environment (a misbehaving FMU): nowhere to deliver the text. */
        return;
    }
    if (message == NULL) {
        e->sink(env, instance_name, status, category, "");
        return;
    }

    va_start(args, message);
    va_copy(again, args);
    needed = vsnprintf(stack_buf, sizeof stack_buf, message, args);
    va_end(args);

    if (needed < 0) {
        /* The format itself is broken: deliver it verbatim rather than nothing. */
        e->sink(env, instance_name, status, category, message);
    } else if ((size_t)needed < sizeof stack_buf) {
        e->sink(env, instance_name, status, category, stack_buf);
    } else {
        size_t size = (size_t)needed + 1;
        char *heap_buf = (char *)malloc(size);
        if (heap_buf != NULL) {
            vsnprintf(heap_buf, size, message, again);
            e->sink(env, instance_name, status, category, heap_buf);
            free(heap_buf);
        } else {
            /* Out of memory: the truncated text is better than losing the message. */
            e->sink(env, instance_name, status, category, stack_buf);
        }
    }
    va_end(again);
}
