"""The robust memory update (docs/model.md §9) applied by a third-party master: the fmpy
master updates the memory with scipy (`butter`, `filtfilt(..., method="gust")`) and must
agree with the orchestrator's own update sample for sample over 5 trials, on the line and
the circle, with the robust setting (Butterworth order 4, 8 Hz, lead 25)."""

from __future__ import annotations

import csv
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from master import ROBUST, Trial, legs, run_trials

SCENARIOS = Path(__file__).resolve().parent / "scenarios"
TRIALS = 5
#: Relative agreement demanded of every sample. scipy and Rust round the filtering in the
#: numerator/denominator form differently (measured: up to 6e-11 of the signal's largest
#: magnitude after 5 trials), so near its zero crossings a sample is held to 1e-9 of the
#: signal's largest magnitude instead of 1e-9 of itself.
RTOL, FLOOR = 1e-9, 1e-9


def assert_close(ours: np.ndarray, theirs: np.ndarray, what: str) -> None:
    scale = float(np.abs(theirs).max())
    worst = float(np.abs(ours - theirs).max()) / scale
    print(f"{what}: largest difference {worst:.2e} of the largest magnitude {scale:.4g}")
    np.testing.assert_allclose(ours, theirs, rtol=RTOL, atol=FLOOR * scale, err_msg=what)


def robust_scenario(trajectory: str, fmu_dir: Path, out: Path) -> Path:
    """`scenarios/<trajectory>-robust.toml` with the FMU paths pointing at `fmu_dir`."""
    text = (SCENARIOS / f"{trajectory}-robust.toml").read_text()
    text, count = re.subn(
        r'^path = ".*/(\w+\.fmu)"$',
        lambda m: f"path = {str(fmu_dir.resolve() / m.group(1))!r}".replace("'", '"'),
        text,
        flags=re.MULTILINE,
    )
    assert count == 2, "the scenario template must name both FMUs"
    path = out / f"{trajectory}-robust.toml"
    path.write_text(text)
    return path


def read_csv(path: Path) -> tuple[dict[str, int], np.ndarray]:
    """Column indices and values of an orchestrator CSV (`time` first)."""
    with path.open(newline="") as f:
        header = next(csv.reader(f))
    return {n: i for i, n in enumerate(header)}, np.loadtxt(
        path, delimiter=",", skiprows=1, ndmin=2
    )


@pytest.fixture(scope="module", params=["line", "circle"])
def trajectory(request: pytest.FixtureRequest) -> str:
    return request.param


@pytest.fixture(scope="module")
def fmpy_trials(fmu_dir: Path, trajectory: str) -> list[Trial]:
    return run_trials(fmu_dir, trajectory=trajectory, trials=TRIALS, update=ROBUST)


@pytest.fixture(scope="module")
def orchestrator_out(
    fmu_dir: Path, orchestrator: Path, trajectory: str, tmp_path_factory: pytest.TempPathFactory
) -> Path:
    work = tmp_path_factory.mktemp(f"robust-{trajectory}")
    scenario = robust_scenario(trajectory, fmu_dir, work)
    out = work / "out"
    run = subprocess.run(
        [str(orchestrator), "run", str(scenario), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, f"orchestrator failed:\n{run.stdout}\n{run.stderr}"
    return out


def test_force_and_memory_match_the_orchestrator(
    fmpy_trials: list[Trial], orchestrator_out: Path
) -> None:
    for k, trial in enumerate(fmpy_trials):
        columns, data = read_csv(orchestrator_out / "trials" / f"trial_{k:03}.csv")
        assert data.shape[0] == len(trial.time), f"trial {k}: rows"
        for ours, var in [(trial.force, "force"), (trial.memory_next, "memory_next")]:
            theirs = data[:, [columns[f"controller.{n}"] for n in legs(var)]]
            assert_close(ours, theirs, f"trial {k}: controller.{var}")
    # The updated memory the orchestrator keeps for trial 5 is the one scipy made.
    columns, memory = read_csv(orchestrator_out / "memory.csv")
    assert_close(fmpy_trials[-1].memory, memory[:, 1:], "memory after the last trial")


def test_the_update_changes_the_memory_and_learning_converges(
    fmpy_trials: list[Trial], trajectory: str
) -> None:
    # The update is not the paper's: the next memory is not the memory_next written.
    assert np.abs(fmpy_trials[0].memory - fmpy_trials[0].memory_next).max() > 1e-3
    max_error = [float(np.abs(t.error).max()) for t in fmpy_trials]
    assert max_error[4] * 10 <= max_error[0], f"max |e| per trial (m): {max_error}"
    if trajectory == "circle":
        # Issue figure: ≤ 0.035 mm by trial 3 with the robust setting.
        assert max_error[3] <= 0.035e-3, f"max |e| per trial (m): {max_error}"


def test_the_golden_filter_values_come_from_the_pinned_scipy() -> None:
    script = Path(__file__).resolve().parent / "make_learning_golden.py"
    run = subprocess.run(
        [sys.executable, str(script), "--check"], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stdout + run.stderr


def test_the_golden_check_tolerates_only_last_bits_of_y() -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import make_learning_golden as golden

    text = golden.GOLDEN.read_text()
    lines = text.splitlines()
    y_at = next(i for i, line in enumerate(lines) if line.startswith("y "))
    b_at = next(i for i, line in enumerate(lines) if line.startswith("b "))

    def with_line(i: int, scale: float) -> str:
        name, *values = lines[i].split()
        changed = [repr(float(values[0]) * scale)] + values[1:]
        return "\n".join(lines[:i] + [" ".join([name, *changed])] + lines[i + 1 :]) + "\n"

    assert golden.compare(text, text) is None
    assert golden.compare(with_line(y_at, 1 + 1e-13), text) is None
    assert "y differs" in golden.compare(with_line(y_at, 1 + 1e-8), text)
    assert "differs" in golden.compare(with_line(b_at, 1 + 1e-15), text)
    assert "lines" in golden.compare(text + "extra\n", text)
