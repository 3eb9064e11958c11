//! The linux64 side: the FMUs' Linux libraries linked for glibc 2.17 with `cargo zigbuild`
//! (why: `fmu_build::linux64`). Its two tools, pinned, are installed when missing into
//! `$CKCM_TOOLS_DIR`, by default `<target dir>/tools`: Zig from PyPI into a virtualenv,
//! `cargo-zigbuild` from crates.io.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result};
use fmu_build::linux64::{self, CARGO_ZIGBUILD_VERSION, Tools, ZIGLANG_VERSION};

use crate::{cargo, output, python, run, target_dir};

/// Where the tools are (`Tools::from_env`), installed or not.
pub fn tools(root: &Path) -> Tools {
    Tools::from_env(&target_dir(root))
}

/// Installs whichever of the two tools is missing or of another version.
pub fn ensure_tools(root: &Path) -> Result<Tools> {
    let tools = tools(root);
    let zig = output(Command::new(tools.python()).args(["-m", "ziglang", "version"])).ok();
    if zig.as_deref().map(str::trim) != Some(ZIGLANG_VERSION) {
        println!(
            "installing Zig {ZIGLANG_VERSION} into {}",
            tools.venv().display()
        );
        run(Command::new("python3")
            .args(["-m", "venv", "--clear"])
            .arg(tools.venv()))?;
        run(python::pip_install(&tools.python()).arg(format!("ziglang=={ZIGLANG_VERSION}")))?;
    }
    let zigbuild = output(Command::new(tools.cargo_zigbuild()).arg("--version")).ok();
    let wanted = format!("cargo-zigbuild {CARGO_ZIGBUILD_VERSION}");
    if zigbuild.as_deref().map(str::trim) != Some(wanted.as_str()) {
        println!("installing {wanted} into {}", tools.dir().display());
        run(Command::new(cargo())
            .args(["install", "--quiet", "--locked", "--force", "--version"])
            .arg(CARGO_ZIGBUILD_VERSION)
            .arg("--root")
            .arg(tools.dir())
            .arg("cargo-zigbuild"))?;
    }
    Ok(tools)
}

/// Builds the given packages in release mode for glibc 2.17; their libraries land in
/// [`release_dir`].
pub fn cargo_build(root: &Path, tools: &Tools, packages: &[&str]) -> Result<()> {
    let mut cmd = tools.build_command(&target_dir(root));
    cmd.current_dir(root);
    for package in packages {
        cmd.args(["-p", package]);
    }
    run(&mut cmd).context("cannot build the linux64 libraries with cargo zigbuild")
}

/// `<target dir>/x86_64-unknown-linux-gnu/release`.
pub fn release_dir(root: &Path) -> PathBuf {
    linux64::release_dir(&target_dir(root))
}
