//! The fmpy side of the test command: a virtualenv with pinned packages, then pytest.

use std::path::Path;
use std::process::Command;

use anyhow::{Result, bail};

use crate::{run, target_dir};

/// `python -m pip install`, quiet; the caller names what to install.
pub fn pip_install(python: &Path) -> Command {
    let mut cmd = Command::new(python);
    cmd.args([
        "-m",
        "pip",
        "install",
        "--quiet",
        "--disable-pip-version-check",
    ]);
    cmd
}

/// Creates `.venv` (if needed) from `tests/python/requirements.txt` and runs pytest on
/// `tests/python`. pytest's exit code 5 ("no tests collected") is a failure here.
pub fn run_pytest(root: &Path) -> Result<()> {
    let venv = root.join(".venv");
    let python = venv.join("bin/python");
    if !python.exists() {
        run(Command::new("python3").arg("-m").arg("venv").arg(&venv))?;
    }
    run(pip_install(&python)
        .arg("-r")
        .arg(root.join("tests/python/requirements.txt")))?;
    let status = Command::new(&python)
        .current_dir(root)
        .args(["-m", "pytest", "tests/python", "-ra"])
        .env("CKCM_FMU_DIR", target_dir(root).join("fmu"))
        .env(
            "CKCM_ORCHESTRATOR",
            target_dir(root).join("release/orchestrator"),
        )
        .status()?;
    match status.code() {
        Some(0) => Ok(()),
        Some(5) => bail!("pytest collected no tests in tests/python"),
        _ => bail!("pytest failed ({status})"),
    }
}
