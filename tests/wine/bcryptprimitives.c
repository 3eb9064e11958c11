/*
 * Test-only stand-in for Windows' bcryptprimitives.dll, which Wine 8.0 lacks.
 *
 * Rust's standard library on Windows draws random bytes (HashMap seeds) from
 * ProcessPrng in bcryptprimitives.dll, present on every Windows 10 and 11. Wine 8.0 has
 * no such DLL, so no Rust program (orchestrator.exe, or an FMU DLL's imports) would
 * start under it. `cargo xtask test` builds this file with mingw-w64 next to the copy of
 * orchestrator.exe it runs under Wine. It is never packaged in an FMU: on Windows the
 * system's own DLL is used.
 */
#include <windows.h>
#include <bcrypt.h>

/* BOOL ProcessPrng(PBYTE pbData, SIZE_T cbData): fills the buffer, always succeeds
 * (Windows documents no failure; we abort rather than hand out unfilled bytes). */
__declspec(dllexport) BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T len)
{
    while (len > 0) {
        ULONG chunk = len > 0x40000000 ? 0x40000000 : (ULONG)len;
        if (!BCRYPT_SUCCESS(BCryptGenRandom(NULL, data, chunk, BCRYPT_USE_SYSTEM_PREFERRED_RNG))) {
            ExitProcess(101);
        }
        data += chunk;
        len -= chunk;
    }
    return TRUE;
}
