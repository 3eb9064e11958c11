//! How the `binaries/linux64` libraries are built, shared by `cargo xtask fmu` and the test
//! that rebuilds the plant elsewhere and compares bytes.
//!
//! A library links against the versions of glibc's symbols that the build machine's glibc
//! offers, and a machine with an older glibc refuses to load it ("version `GLIBC_2.34' not
//! found"). Built on Debian 12, the FMUs asked for glibc 2.34, so RHEL 8, Ubuntu 20.04 and
//! most clusters could not load them. `cargo zigbuild` links with Zig against stubs of the
//! glibc given in the target name, so the same code loads wherever glibc is at least
//! [`GLIBC`]: the oldest Rust's standard library supports on x86-64 (RHEL 7). Compiling is
//! still rustc's, and libm stays the host's at run time, so the results are the same bits.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The oldest glibc the libraries load on.
pub const GLIBC: &str = "2.17";

/// Rust's target of the libraries.
pub const RUST_TARGET: &str = "x86_64-unknown-linux-gnu";

/// The PyPI package that ships the Zig compiler, pinned: another Zig links other bytes,
/// and a campaign's fingerprint holds the FMUs' bytes.
pub const ZIGLANG_VERSION: &str = "0.17.1";

/// The cargo subcommand that links with Zig, pinned for the same reason.
pub const CARGO_ZIGBUILD_VERSION: &str = "0.24.1";

/// Where the two build tools are installed: `<dir>/zig-venv` (a virtualenv holding
/// `ziglang`) and `<dir>/bin/cargo-zigbuild`.
#[derive(Debug, Clone)]
pub struct Tools {
    dir: PathBuf,
}

/// The environment variable naming the tools' folder.
pub const TOOLS_DIR_VAR: &str = "CKCM_TOOLS_DIR";

impl Tools {
    /// The tools of `dir`, installed or not.
    pub fn in_dir(dir: impl Into<PathBuf>) -> Self {
        Self { dir: dir.into() }
    }

    /// The tools of `$CKCM_TOOLS_DIR`, else of `<target_dir>/tools`, where `cargo xtask fmu`
    /// installs them.
    pub fn from_env(target_dir: &Path) -> Self {
        Self::in_dir(
            std::env::var_os(TOOLS_DIR_VAR)
                .filter(|d| !d.is_empty())
                .map(PathBuf::from)
                .unwrap_or_else(|| target_dir.join("tools")),
        )
    }

    /// The folder holding both tools.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The virtualenv holding `ziglang`.
    pub fn venv(&self) -> PathBuf {
        self.dir.join("zig-venv")
    }

    /// The virtualenv's Python, which runs Zig as `python -m ziglang`.
    pub fn python(&self) -> PathBuf {
        self.venv().join("bin/python")
    }

    /// The `cargo-zigbuild` executable.
    pub fn cargo_zigbuild(&self) -> PathBuf {
        self.dir.join("bin/cargo-zigbuild")
    }

    /// `cargo zigbuild --release --quiet --target x86_64-unknown-linux-gnu.2.17`, writing to
    /// `target_dir`; the caller adds `-p` for each package and runs it in the workspace.
    pub fn build_command(&self, target_dir: &Path) -> Command {
        let mut cmd = Command::new(self.cargo_zigbuild());
        cmd.arg("zigbuild")
            .args(["--release", "--quiet", "--target"])
            .arg(format!("{RUST_TARGET}.{GLIBC}"))
            .env("CARGO_TARGET_DIR", target_dir)
            .env("CARGO_ZIGBUILD_PYTHON_PATH", self.python());
        cmd
    }
}

/// The folder the libraries of [`Tools::build_command`] land in.
pub fn release_dir(target_dir: &Path) -> PathBuf {
    target_dir.join(RUST_TARGET).join("release")
}
