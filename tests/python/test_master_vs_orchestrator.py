"""The fmpy master and the Rust orchestrator run the same three HLCS trials and must agree
bit for bit on every recorded signal; under fmpy alone, learning must cut the error."""

from __future__ import annotations

import csv
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from master import Trial, legs, run_trials

SCENARIOS = Path(__file__).resolve().parent / "scenarios"
TRAJECTORIES = ["line", "circle"]
TRIALS = 3
#: Every signal the two masters record, compared with exact equality: both call the same
#: FMU binaries with the same inputs in the same order, and the CSV keeps each double's
#: shortest round-trip spelling, so any difference is a difference in the masters.
SIGNALS = [
    ("force", "controller"),
    ("error", "controller"),
    ("memory_next", "controller"),
    ("length", "plant"),
    ("velocity", "plant"),
    ("pose", "plant"),
]


def scenario_with_absolute_paths(trajectory: str, fmu_dir: Path, out: Path) -> Path:
    """Copies `scenarios/<trajectory>-hlcs.toml` into `out` with the FMU paths pointing at
    `fmu_dir` (scenario paths are relative to the scenario file)."""
    text = (SCENARIOS / f"{trajectory}-hlcs.toml").read_text()
    text, count = re.subn(
        r'^path = ".*/(\w+\.fmu)"$',
        lambda m: f"path = {str(fmu_dir.resolve() / m.group(1))!r}".replace("'", '"'),
        text,
        flags=re.MULTILINE,
    )
    assert count == 2, "the scenario template must name both FMUs"
    path = out / f"{trajectory}-hlcs.toml"
    path.write_text(text)
    return path


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    """Header and values of an orchestrator CSV (`time` first)."""
    with path.open(newline="") as f:
        header = next(csv.reader(f))
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


@pytest.fixture(scope="module", params=TRAJECTORIES)
def trajectory(request: pytest.FixtureRequest) -> str:
    return request.param


@pytest.fixture(scope="module")
def fmpy_trials(fmu_dir: Path, trajectory: str) -> list[Trial]:
    return run_trials(fmu_dir, trajectory=trajectory, trials=TRIALS)


@pytest.fixture(scope="module")
def orchestrator_out(
    fmu_dir: Path, orchestrator: Path, trajectory: str, tmp_path_factory: pytest.TempPathFactory
) -> Path:
    work = tmp_path_factory.mktemp(f"orchestrator-{trajectory}")
    scenario = scenario_with_absolute_paths(trajectory, fmu_dir, work)
    out = work / "out"
    run = subprocess.run(
        [str(orchestrator), "run", str(scenario), "--out", str(out), "--trials", str(TRIALS)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, f"orchestrator failed:\n{run.stdout}\n{run.stderr}"
    return out


def test_every_sample_matches_the_orchestrator(
    fmpy_trials: list[Trial], orchestrator_out: Path
) -> None:
    for k, trial in enumerate(fmpy_trials):
        header, data = read_csv(orchestrator_out / "trials" / f"trial_{k:03}.csv")
        assert header[0] == "time"
        width = 1 + len(SIGNALS) * 6
        assert data.shape == (len(trial.time), width), f"trial {k}: rows or columns"
        # Row n is sample n at t_n = n·h in both (same formula, so equal to the bit).
        np.testing.assert_array_equal(data[:, 0], trial.time, err_msg=f"trial {k}: time")
        columns = {name: i for i, name in enumerate(header)}
        for var, fmu in SIGNALS:
            ours = getattr(trial, var)
            theirs = data[:, [columns[f"{fmu}.{n}"] for n in legs(var)]]
            np.testing.assert_array_equal(ours, theirs, err_msg=f"trial {k}: {fmu}.{var}")
    # The memory the orchestrator saved for a next trial is what fmpy would carry over.
    last = TRIALS - 1
    _, memory = read_csv(orchestrator_out / "memory.csv")
    np.testing.assert_array_equal(fmpy_trials[last].memory_next, memory[:, 1:], err_msg="memory")


def test_learning_cuts_the_error_fivefold_by_trial_2(fmpy_trials: list[Trial]) -> None:
    max_error = [float(np.abs(t.error).max()) for t in fmpy_trials]
    assert max_error[0] > 1e-4, f"trial 0 should show the model mismatch: {max_error}"
    assert max_error[2] * 5 <= max_error[0], f"max |e| per trial (m): {max_error}"
    # Learning really ran: trial 1 read a non-zero memory and wrote a different one.
    assert np.abs(fmpy_trials[0].memory_next).max() > 1.0
    assert not np.array_equal(fmpy_trials[1].memory_next, fmpy_trials[0].memory_next)
