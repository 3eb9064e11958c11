"""The FMU-state API through fmpy: get/set rewinds an instance, and serialized bytes
restore the state in a freshly instantiated one."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from master import STEP_SIZE, Slave, legs

H = STEP_SIZE
#: Steps to 1 s, where the state is saved, and to 1.5 s, the end of each replay.
N_SAVE, N_END = 1000, 1500


def plant_inputs(t: float) -> list[float]:
    """Hold forces plus a leg-alternating wobble, so the plant really moves."""
    wobble = 3.0 * np.sin(2 * np.pi * 0.7 * t)
    return [28.5315 + wobble * (-1) ** i for i in range(6)]


def controller_inputs(t: float) -> list[float]:
    """Measured lengths and rates that stray from the reference, and a moving memory."""
    length = [0.5667144462950593 + 1e-3 * np.sin(3 * t + i) for i in range(6)]
    velocity = [3e-3 * np.cos(3 * t + i) for i in range(6)]
    memory = [np.sin(t + i) for i in range(6)]
    return length + velocity + memory


@dataclass
class Case:
    """One FMU, driven by a known input signal; non-default parameters check that they
    travel with the state into a fresh instance (which has only the defaults)."""

    fmu: str
    inputs: list[str]
    outputs: list[str]
    drive: Callable[[float], list[float]]
    reals: dict[str, float] = field(default_factory=dict)
    integers: dict[str, int] = field(default_factory=dict)
    #: Enumeration variables set by item name (values from the model description).
    enumerations: dict[str, str] = field(default_factory=dict)


CASES = {
    "plant": Case(
        fmu="CkcmPlant.fmu",
        inputs=legs("force"),
        outputs=legs("length") + legs("velocity") + legs("pose"),
        drive=plant_inputs,
        reals={"viscous_friction": 150.0},
    ),
    "controller": Case(
        fmu="HlcsController.fmu",
        inputs=legs("length") + legs("velocity") + legs("memory"),
        outputs=legs("force") + legs("memory_next") + legs("error"),
        drive=controller_inputs,
        reals={"duration": 5.0},
        enumerations={"trajectory": "circle"},
    ),
}


def run(slave: Slave, case: Case, n_from: int, n_to: int) -> np.ndarray:
    """Steps n_from..n_to with the case's inputs; one row of outputs after each step."""
    in_vrs, out_vrs = slave.vrs(case.inputs), slave.vrs(case.outputs)
    rows = []
    for n in range(n_from, n_to):
        t = n * H
        slave.fmu.setReal(in_vrs, case.drive(t))
        # False: the master may rewind to an earlier state, so the FMU must keep it.
        slave.fmu.doStep(t, H, False)
        rows.append(slave.fmu.getReal(out_vrs))
    return np.array(rows)


@pytest.mark.parametrize("name", list(CASES))
def test_get_set_and_serialized_state_replay_identically(fmu_dir: Path, name: str) -> None:
    case = CASES[name]
    first = Slave(fmu_dir / case.fmu, f"{name}-first")
    try:
        first.start(
            0.0,
            N_END * H,
            reals=case.reals,
            integers=case.integers,
            enumerations=case.enumerations,
        )
        run(first, case, 0, N_SAVE)
        state = first.fmu.getFMUstate()
        reference = run(first, case, N_SAVE, N_END)
        assert np.all(np.isfinite(reference))
        assert np.ptp(reference, axis=0).max() > 1e-6, "the outputs must move over the replay"

        # Rewind the same instance and replay.
        first.fmu.setFMUstate(state)
        np.testing.assert_array_equal(run(first, case, N_SAVE, N_END), reference)

        serialized = first.fmu.serializeFMUstate(state)
        assert isinstance(serialized, bytes) and len(serialized) > 0
        first.fmu.freeFMUstate(state)
    finally:
        first.close()

    # A fresh instance, never initialized and with default parameters, continues from the
    # bytes alone.
    second = Slave(fmu_dir / case.fmu, f"{name}-second")
    try:
        restored = second.fmu.deSerializeFMUstate(serialized)
        second.fmu.setFMUstate(restored)
        second.fmu.freeFMUstate(restored)
        np.testing.assert_array_equal(run(second, case, N_SAVE, N_END), reference)
    finally:
        second.close()
