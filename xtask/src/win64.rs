//! The win64 side: the cross toolchain (rustup's `x86_64-pc-windows-gnu` target and
//! Debian's mingw-w64), installed when missing, and Wine to run the cross-built
//! `orchestrator.exe` in the tests.
//!
//! Nothing here is skipped quietly: a tool that is missing and cannot be installed is an
//! error naming the command that would install it.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::{cargo, output, run, target_dir};

/// Rust's target for 64-bit Windows with the MinGW-w64 toolchain (linker and flags in
/// `.cargo/config.toml`).
pub const TARGET: &str = "x86_64-pc-windows-gnu";

/// The MinGW-w64 C compiler, which Rust uses as the linker (and `cc` for C code).
const MINGW_GCC: &str = "x86_64-w64-mingw32-gcc";

/// The test-only stand-in for Wine's incomplete `bcryptprimitives.dll`, placed beside every
/// executable the Wine tests run.
const STAND_IN_DLL: &str = "bcryptprimitives.dll";

/// `<target dir>/wine`: `bin` (orchestrator.exe and the stand-in DLL) and `prefix` (the
/// Wine prefix).
fn wine_dir(target: &Path) -> PathBuf {
    target.join("wine")
}

/// `<target dir>/x86_64-pc-windows-gnu/release`.
pub fn release_dir(target: &Path) -> PathBuf {
    target.join(TARGET).join("release")
}

/// The file name of the DLL of the library crate `lib_name` on this target (no prefix).
pub fn dll_file_name(lib_name: &str) -> String {
    format!("{lib_name}.dll")
}

/// Installs the rustup target and mingw-w64 when missing.
pub fn ensure_cross_toolchain() -> Result<()> {
    let installed = output(Command::new("rustup").args(["target", "list", "--installed"]))
        .context("rustup is needed to add the x86_64-pc-windows-gnu target")?;
    if !installed.lines().any(|l| l.trim() == TARGET) {
        println!("installing the Rust target {TARGET}");
        run(Command::new("rustup").args(["target", "add", TARGET]))?;
    }
    if !on_path(MINGW_GCC) {
        apt_install(&["gcc-mingw-w64-x86-64"], MINGW_GCC)?;
    }
    Ok(())
}

/// Installs Wine when missing.
pub fn ensure_wine() -> Result<()> {
    if !on_path("wine") {
        apt_install(&["wine", "wine64"], "wine")?;
    }
    Ok(())
}

/// Builds the given packages in release mode for win64.
pub fn cargo_build(root: &Path, packages: &[&str]) -> Result<()> {
    let mut cmd = Command::new(cargo());
    cmd.current_dir(root)
        .env("CARGO_TARGET_DIR", target_dir(root))
        .args(["build", "--release", "--quiet", "--target", TARGET]);
    for package in packages {
        cmd.args(["-p", package]);
    }
    run(&mut cmd)
}

/// Cross-builds `orchestrator.exe`, copies it into `<target dir>/wine/bin` beside the
/// test-only `bcryptprimitives.dll` stand-in (built from `tests/wine/bcryptprimitives.c`),
/// and creates the Wine prefix `<target dir>/wine/prefix` if needed. Returns the
/// environment the Wine tests read.
pub fn prepare_wine(root: &Path) -> Result<Vec<(&'static str, PathBuf)>> {
    ensure_wine()?;
    cargo_build(root, &["orchestrator"])?;
    let target = target_dir(root);
    let dir = wine_dir(&target);
    let bin = dir.join("bin");
    fs::create_dir_all(&bin).with_context(|| format!("cannot create {}", bin.display()))?;
    let exe = bin.join("orchestrator.exe");
    let built = release_dir(&target).join("orchestrator.exe");
    fs::copy(&built, &exe)
        .with_context(|| format!("cannot copy {} to {}", built.display(), exe.display()))?;
    run(Command::new(MINGW_GCC)
        .args([
            "-shared",
            "-O2",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-static-libgcc",
        ])
        .arg("-o")
        .arg(bin.join(STAND_IN_DLL))
        .arg(root.join("tests/wine/bcryptprimitives.c"))
        .arg("-lbcrypt"))?;

    let prefix = dir.join("prefix");
    if !prefix.join("system.reg").is_file() {
        println!("creating the Wine prefix {}", prefix.display());
        run(wine_command(&prefix, "wineboot").arg("--init"))?;
        // wineboot returns before the prefix is written out; wait for its wineserver.
        run(wine_command(&prefix, "wineserver").arg("--wait"))?;
        if !prefix.join("system.reg").is_file() {
            bail!(
                "wineboot did not create the Wine prefix {}",
                prefix.display()
            );
        }
    }
    Ok(vec![
        ("CKCM_WINE_ORCHESTRATOR", exe),
        ("WINEPREFIX", prefix),
    ])
}

/// The FMU-level Rust tests that drive the packaged FMUs through the C ABI, cross-built for
/// win64 and run under Wine, so the same checks hold for the DLLs Windows tools load: every
/// function in every state, batches, refused inputs, the workspace limits, and mutated
/// serialized states.
const WIN64_ABI_TESTS: &[&str] = &[
    "fmu_illegal_calls",
    "fmu_abi",
    "fmu_hardening",
    "fuzz_fmu_state",
];

/// Runs [`WIN64_ABI_TESTS`] under Wine against the FMUs in `<target dir>/fmu`, in the Wine
/// prefix and with the stand-in DLL that [`prepare_wine`] made.
pub fn run_abi_tests(root: &Path) -> Result<()> {
    let target = target_dir(root);
    let test = |extra: &[&str]| {
        // Cargo runs each test executable with `wine`, which takes the prefix and the quiet
        // settings from the environment it inherits.
        let mut cmd = wine_command(&wine_dir(&target).join("prefix"), cargo().as_str());
        cmd.current_dir(root)
            .env("CARGO_TARGET_DIR", &target)
            .env("CARGO_TARGET_X86_64_PC_WINDOWS_GNU_RUNNER", "wine")
            .env("CKCM_FMU_DIR", wine_path(&target.join("fmu")))
            .args([
                "test",
                "--release",
                "--quiet",
                "--target",
                TARGET,
                "-p",
                "orchestrator",
            ]);
        for name in WIN64_ABI_TESTS {
            cmd.args(["--test", name]);
        }
        cmd.args(extra);
        cmd
    };
    run(&mut test(&["--no-run"]))?;
    // The test executables find the stand-in beside them, as orchestrator.exe does.
    let from = wine_dir(&target).join("bin").join(STAND_IN_DLL);
    let to = release_dir(&target).join("deps").join(STAND_IN_DLL);
    fs::copy(&from, &to)
        .with_context(|| format!("cannot copy {} to {}", from.display(), to.display()))?;
    run(&mut test(&[]))
}

/// The Windows name Wine gives a Linux path (its `Z:` drive is `/`).
fn wine_path(path: &Path) -> String {
    format!("Z:{}", path.display()).replace('/', "\\")
}

/// A Wine tool run in `prefix`, quiet, without the Mono and Gecko installers (a console
/// program needs neither).
fn wine_command(prefix: &Path, program: &str) -> Command {
    let mut cmd = Command::new(program);
    cmd.env("WINEPREFIX", prefix)
        .env("WINEDEBUG", "-all")
        .env("WINEDLLOVERRIDES", "mscoree,mshtml=");
    cmd
}

/// `apt-get install` of Debian packages, non-interactive; only as root (as on CI).
fn apt_install(packages: &[&str], missing: &str) -> Result<()> {
    let command = format!("apt-get install {}", packages.join(" "));
    let is_root = output(Command::new("id").arg("-u")).is_ok_and(|uid| uid.trim() == "0");
    if !is_root {
        bail!("`{missing}` is not installed; install it as root with `{command}`");
    }
    if !on_path("apt-get") {
        bail!("`{missing}` is not installed and there is no apt-get: install {packages:?}");
    }
    println!("installing {} (for {missing})", packages.join(", "));
    let apt = |args: &[&str]| {
        let mut cmd = Command::new("apt-get");
        // Wait for another apt/dpkg run to finish instead of failing on its lock.
        cmd.env("DEBIAN_FRONTEND", "noninteractive")
            .args(["-o", "DPkg::Lock::Timeout=600", "-q"])
            .args(args);
        cmd
    };
    run(&mut apt(&["update"])).with_context(|| format!("{command} needs apt-get update"))?;
    run(apt(&["install", "-y", "--no-install-recommends"]).args(packages))?;
    if !on_path(missing) {
        bail!("`{command}` succeeded but `{missing}` is still not on PATH");
    }
    Ok(())
}

/// Whether `program` is an executable in a directory of `PATH`.
fn on_path(program: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|path| {
        std::env::split_paths(&path)
            .any(|dir| fs::metadata(dir.join(program)).is_ok_and(|m| m.is_file()))
    })
}
