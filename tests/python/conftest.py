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

#: What the packaged FMUs are built from, as `tests/fmu-sources.txt` lists them.
FMU_SOURCES = [
    line.strip()
    for line in (REPO / "tests" / "fmu-sources.txt").read_text().splitlines()
    if line.strip() and not line.lstrip().startswith("#")
]
#: What the orchestrator binary is built from.
ORCHESTRATOR_SOURCES = [
    "Cargo.lock",
    "ckcm/Cargo.toml",
    "ckcm/src",
    "fmi/fmi2-sys/Cargo.toml",
    "fmi/fmi2-sys/src",
    "fmi/fmi2-md/Cargo.toml",
    "fmi/fmi2-md/src",
    "fmi/fmi2-import/Cargo.toml",
    "fmi/fmi2-import/build.rs",
    "fmi/fmi2-import/csrc",
    "fmi/fmi2-import/src",
    "orchestrator/Cargo.toml",
    "orchestrator/src",
]


def newest_source(paths: list[str]) -> tuple[float, Path] | None:
    """The newest modification time among the files under `paths` (relative to the
    repository; missing ones skipped), with the file."""
    newest: tuple[float, Path] | None = None
    for p in paths:
        root = REPO / p
        files = [root] if root.is_file() else [f for f in root.rglob("*") if f.is_file()]
        for f in files:
            mtime = f.stat().st_mtime
            if newest is None or mtime > newest[0]:
                newest = (mtime, f)
    return newest


def fail_if_stale(artifact: Path, sources: list[str], rebuild: str) -> None:
    """Fails loudly when `artifact` is older than a file it is built from: a stale FMU or
    binary would test old code and pass."""
    newest = newest_source(sources)
    if newest is not None and artifact.stat().st_mtime < newest[0]:
        pytest.fail(
            f"{artifact} is older than {newest[1]}: it was built from other sources; "
            f"run `{rebuild}`",
            pytrace=False,
        )


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
    for name in ("CkcmPlant.fmu", "HlcsController.fmu"):
        fail_if_stale(directory / name, FMU_SOURCES, "cargo xtask fmu")
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
    fail_if_stale(path, ORCHESTRATOR_SOURCES, "cargo build --release -p orchestrator")
    return path
