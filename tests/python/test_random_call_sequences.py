"""Random FMI call sequences (`random_calls.py`) against each shipped FMU's binary.

The FMUs are meant to survive whatever a master does: every misuse is answered with a
status and a logged message, never a crash. Each seed runs in its own process, so a
segmentation fault or an abort fails one test with the command that replays it.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
SEEDS = [1, 2, 3, 4]
SEQUENCES = 250
#: fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal (no fmi2Pending: no FMU steps
#: asynchronously).
STATUSES = {"0", "1", "2", "3", "5"}


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("name", ["CkcmPlant", "HlcsController"])
def test_random_calls_get_a_status_and_never_crash(fmu_dir: Path, name: str, seed: int) -> None:
    fmu = fmu_dir / f"{name}.fmu"
    command = [sys.executable, str(HERE / "random_calls.py"), str(fmu), str(seed), str(SEQUENCES)]
    run = subprocess.run(command, check=False, capture_output=True, text=True, timeout=600)
    replay = " ".join(command)
    if run.returncode < 0:
        pytest.fail(
            f"{name} crashed ({signal.Signals(-run.returncode).name}); replay: {replay}\n"
            f"{run.stderr[-2000:]}"
        )
    assert run.returncode == 0, f"{replay} exited {run.returncode}:\n{run.stderr[-2000:]}"
    summary = json.loads(run.stdout.strip().splitlines()[-1])

    # The sequences reached the interesting states: instances were made and stepped.
    assert summary["instances"] > SEQUENCES // 3, summary["instances"]
    assert summary["legal_steps"] > 1000, summary["legal_steps"]
    # A foreign GUID or a Model Exchange request is refused at instantiation.
    assert summary["foreign_guid_accepted"] == 0
    assert summary["wrong_type_accepted"] == 0
    # Every call answered with a status FMI 2.0 defines, and every message had text.
    odd = {f: s for f, counts in summary["statuses"].items() for s in counts if s not in STATUSES}
    assert not odd, f"statuses outside FMI 2.0's: {odd}; replay: {replay}"
    assert summary["null_messages"] == 0
    # Both outcomes occurred for the calls that matter most, so the test exercised them.
    for function in ("fmi2SetReal", "fmi2GetReal", "fmi2DoStep", "fmi2DeSerializeFMUstate"):
        counts = summary["statuses"].get(function, {})
        assert "0" in counts and "3" in counts, f"{function}: {counts}"
