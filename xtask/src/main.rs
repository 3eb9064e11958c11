//! Project automation, so a fresh machine needs only `cargo`:
//!
//! - `cargo xtask fmu`: build every FMU crate of the workspace (each member with a
//!   `[package.metadata.fmu]` table: `CkcmPlant`, `HlcsController` and the test fixture
//!   `ForeignOscillator`) in release mode, for Linux (linked for glibc 2.17 with Zig) and
//!   (cross, with mingw-w64) for win64, and package `target/fmu/<modelIdentifier>.fmu`.
//!   Installs the Rust target, mingw-w64, Zig and `cargo-zigbuild` if missing.
//! - `cargo xtask paper [ARGS...]`: package the FMUs, then run the paper study through the
//!   orchestrator (`orchestrator paper ARGS...`), writing `results/paper/`.
//! - `cargo xtask test`: check formatting and clippy, package the FMUs, cross-build
//!   `orchestrator.exe` and prepare Wine (installed if missing) for the win64 tests, run
//!   every Rust test, run the FMU-level ABI tests again cross-built for win64 under Wine
//!   against the DLLs, create the Python virtualenv (pinned fmpy, numpy, pytest) and run
//!   the fmpy tests.
#![deny(unsafe_code)]

mod docs;
mod linux64;
mod package;
mod python;
mod win64;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{Context, Result, bail};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let root = workspace_root();
    match args.first().map(String::as_str) {
        Some("fmu") => {
            package::build_fmus(&root)?;
        }
        Some("paper") => {
            package::build_fmus(&root)?;
            run(Command::new(cargo())
                .current_dir(&root)
                .args([
                    "run",
                    "--release",
                    "--quiet",
                    "-p",
                    "orchestrator",
                    "--",
                    "paper",
                ])
                .env("CARGO_TARGET_DIR", target_dir(&root))
                .arg("--fmu-dir")
                .arg(target_dir(&root).join("fmu"))
                .args(&args[1..]))?;
        }
        Some("test") => {
            // House rules first: formatting and clippy with warnings as errors.
            run(Command::new(cargo())
                .current_dir(&root)
                .args(["fmt", "--all", "--", "--check"]))?;
            run(Command::new(cargo())
                .current_dir(&root)
                .env("CARGO_TARGET_DIR", target_dir(&root))
                .args([
                    "clippy",
                    "--workspace",
                    "--all-targets",
                    "--quiet",
                    "--",
                    "-D",
                    "warnings",
                ]))?;
            package::build_fmus(&root)?;
            let wine_env = win64::prepare_wine(&root)?;
            run(Command::new(cargo())
                .current_dir(&root)
                .args(["test", "--workspace", "--release"])
                .env("CARGO_TARGET_DIR", target_dir(&root))
                .env("CKCM_FMU_DIR", target_dir(&root).join("fmu"))
                .env(
                    fmu_build::linux64::TOOLS_DIR_VAR,
                    linux64::tools(&root).dir(),
                )
                .envs(wine_env))?;
            win64::run_abi_tests(&root)?;
            python::run_pytest(&root)?;
        }
        _ => bail!(
            "usage: cargo xtask <fmu | paper [ARGS...] | test>\n  \
             fmu    build and package target/fmu/*.fmu\n  \
             paper  package the FMUs and run the paper study (results/paper/)\n  \
             test   package the FMUs and run every Rust and fmpy test"
        ),
    }
    Ok(())
}

/// The workspace root (this crate's parent directory).
fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives in the workspace")
        .to_path_buf()
}

/// Cargo's target directory: `$CARGO_TARGET_DIR` when set (relative to the directory
/// `cargo xtask` was started in, as cargo reads it), else `<workspace>/target`. Builds,
/// packaged FMUs and the binaries the tests run all live here, so with the variable set
/// nothing stale from `<workspace>/target` is packaged or tested.
pub fn target_dir(root: &Path) -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR").filter(|d| !d.is_empty()) {
        Some(dir) => std::env::current_dir()
            .map(|cwd| cwd.join(&dir))
            .unwrap_or_else(|_| PathBuf::from(dir)),
        None => root.join("target"),
    }
}

/// The cargo that runs us, so toolchain overrides carry over.
fn cargo() -> String {
    std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string())
}

/// The standard output of a command that must succeed.
pub fn output(cmd: &mut Command) -> Result<String> {
    let out = cmd
        .stderr(Stdio::inherit())
        .output()
        .with_context(|| format!("cannot start {cmd:?}"))?;
    if !out.status.success() {
        bail!("{cmd:?} failed with {}", out.status);
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Runs a command, failing with its command line if it does not succeed.
pub fn run(cmd: &mut Command) -> Result<()> {
    let status = cmd
        .status()
        .with_context(|| format!("cannot start {cmd:?}"))?;
    if !status.success() {
        bail!("{cmd:?} failed with {status}");
    }
    Ok(())
}
