//! Compiles the C logger shim: `fmi2CallbackLogger` is C-variadic, which Rust can call but
//! not define.

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-changed=csrc/logger.c");
    cc::Build::new()
        .file("csrc/logger.c")
        .warnings(true)
        .extra_warnings(true)
        .compile("fmi2_import_logger");
}
