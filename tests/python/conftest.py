"""Shared fixtures: where the FMUs and the orchestrator binary are.

`cargo xtask test` passes `CKCM_FMU_DIR` and `CKCM_ORCHESTRATOR`; run by hand, the
defaults are `<repo>/target/fmu` and `<repo>/target/release/orchestrator`. A missing
artifact fails the test with the command that builds it (never a silent skip).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from master import default_fmu_dir  # noqa: E402

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def fmu_dir() -> Path:
    """The directory holding CkcmPlant.fmu and HlcsController.fmu."""
    directory = default_fmu_dir()
    missing = [
        name for name in ("CkcmPlant.fmu", "HlcsController.fmu") if not (directory / name).is_file()
    ]
    if missing:
        pytest.fail(
            f"{', '.join(missing)} not found in {directory}: run `cargo xtask fmu` "
            "or set CKCM_FMU_DIR",
            pytrace=False,
        )
    return directory


@pytest.fixture(scope="session")
def plant_fmu(fmu_dir: Path) -> Path:
    return fmu_dir / "CkcmPlant.fmu"


@pytest.fixture(scope="session")
def controller_fmu(fmu_dir: Path) -> Path:
    return fmu_dir / "HlcsController.fmu"


@pytest.fixture(scope="session")
def orchestrator() -> Path:
    """The orchestrator binary: `$CKCM_ORCHESTRATOR`, else the release build."""
    env = os.environ.get("CKCM_ORCHESTRATOR")
    path = Path(env) if env else REPO / "target" / "release" / "orchestrator"
    if not (path.is_file() and os.access(path, os.X_OK)):
        pytest.fail(
            f"orchestrator binary {path} not found: run "
            "`cargo build --release -p orchestrator` or set CKCM_ORCHESTRATOR",
            pytrace=False,
        )
    return path
