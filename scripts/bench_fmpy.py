"""Times the coupled 15 s line trial (HLCS) under the fmpy reference master and compares it
with the orchestrator.

The fmpy master is the one of tests/python/master.py. Trial 0 runs once untimed and
learns a memory; every timed trial starts from that same memory, so each repeat does
the same work as the orchestrator's benchmarked trial (trial >= 1, non-zero memory).

The orchestrator's time per trial is either given (``--orchestrator-seconds``, e.g. the
criterion median of ``line_trial_15s/orchestrator``) or measured here with the release CLI
on a generated scenario: the wall time of ``run --trials 1+K`` minus that of
``run --trials 1``, over K. That difference leaves out process start, FMU unpacking and
trial 0, but keeps the CLI's per-trial output (memory CSV, summary, progress file).

Run from the repository root:

    cargo xtask fmu && cargo build --release -p orchestrator
    .venv/bin/python scripts/bench_fmpy.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "python"))

from master import HlcsMaster, default_fmu_dir  # noqa: E402

#: Length of the paper's line trial (s), and so of one simulated trial.
TRIAL_SECONDS = 15.0

#: The fmpy master should be at least this many times slower than the orchestrator.
TARGET_RATIO = 12.0

SCENARIO = """\
step_size = 0.001
stop_time = 15.0
trials = 1

[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "line"
duration = 15.0
learning = true
psi = 7.5

[[fmu]]
name = "plant"
path = "{plant}"

[[connection]]
from = "plant.length"
to = "controller.length"

[[connection]]
from = "plant.velocity"
to = "controller.velocity"

[[connection]]
from = "controller.force"
to = "plant.force"

[[memory]]
from = "controller.memory_next"
to = "controller.memory"

[record]
variables = ["controller.error"]
trials = [0]

[metrics]
error = "controller.error"
"""


def time_fmpy(fmu_dir: Path, repeats: int) -> list[float]:
    """Seconds of each of `repeats` line trials under the fmpy master, all from trial 0's memory."""
    master = HlcsMaster(fmu_dir, trajectory="line", duration=TRIAL_SECONDS)
    try:
        master.run_trial()  # trial 0: learns the memory (and warms caches)
        learned = master.memory.copy()
        if not learned.any():
            raise RuntimeError("trial 0 learned no memory: is learning on?")
        times = []
        for _ in range(repeats):
            master.memory = learned.copy()
            started = time.perf_counter()
            master.run_trial()
            times.append(time.perf_counter() - started)
        return times
    finally:
        master.close()


def time_orchestrator_cli(binary: Path, fmu_dir: Path, repeats: int, extra: int) -> float:
    """Median seconds per trial of `binary run`, from runs with 1 and 1 + `extra` trials."""
    with tempfile.TemporaryDirectory(prefix="bench-fmpy-") as tmp:
        scenario = Path(tmp) / "line.toml"
        scenario.write_text(
            SCENARIO.format(
                controller=(fmu_dir / "HlcsController.fmu").resolve(),
                plant=(fmu_dir / "CkcmPlant.fmu").resolve(),
            )
        )

        def wall(trials: int) -> float:
            # --force: every run reuses the folder, which a finished campaign occupies.
            # --jobs 1: one lane, one trial at a time, as the fmpy master runs them; on more
            # cores the CLI would run trials side by side and halve the time per trial.
            cmd = [
                str(binary), "run", str(scenario), "--trials", str(trials), "--out", tmp + "/out", "--force",
                "--jobs", "1",
            ]
            started = time.perf_counter()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            return time.perf_counter() - started

        one = statistics.median(wall(1) for _ in range(repeats))
        many = statistics.median(wall(1 + extra) for _ in range(repeats))
    return (many - one) / extra


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5, help="timed trials (default 5)")
    parser.add_argument("--fmu-dir", type=Path, default=default_fmu_dir())
    source = parser.add_mutually_exclusive_group()
    source.add_argument(
        "--orchestrator-seconds",
        type=float,
        help="the orchestrator's median seconds per 15 s trial (skips running the CLI)",
    )
    source.add_argument(
        "--orchestrator",
        type=Path,
        default=Path(os.environ.get("CKCM_ORCHESTRATOR", REPO / "target/release/orchestrator")),
        help="orchestrator binary to time (default: $CKCM_ORCHESTRATOR or target/release/orchestrator)",
    )
    source.add_argument("--no-orchestrator", action="store_true", help="time fmpy only")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")

    times = time_fmpy(args.fmu_dir, args.repeats)
    fmpy_s = statistics.median(times)
    print(
        f"fmpy master: median {fmpy_s:.3f} s per 15 s line trial "
        f"({TRIAL_SECONDS / fmpy_s:.1f}x real time; {args.repeats} trials: "
        + ", ".join(f"{t:.3f}" for t in times)
        + ")"
    )
    if args.no_orchestrator:
        return
    if args.orchestrator_seconds is not None:
        orch_s, how = args.orchestrator_seconds, "given"
    else:
        if not (args.orchestrator.is_file() and os.access(args.orchestrator, os.X_OK)):
            sys.exit(
                f"{args.orchestrator} not found: run `cargo build --release -p orchestrator`, "
                "or pass --orchestrator-seconds or --no-orchestrator"
            )
        orch_s = time_orchestrator_cli(args.orchestrator, args.fmu_dir, args.repeats, extra=5)
        how = f"{args.orchestrator.name} run, (T(6 trials) - T(1 trial)) / 5, median of {args.repeats}"
    ratio = fmpy_s / orch_s
    verdict = "met" if ratio >= TARGET_RATIO else "missed"
    print(f"orchestrator: {orch_s:.4f} s per 15 s line trial ({how})")
    print(f"ratio fmpy / orchestrator: {ratio:.1f} (target >= {TARGET_RATIO:.0f}: {verdict})")


if __name__ == "__main__":
    main()
