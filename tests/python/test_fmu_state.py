"""The FMU-state API through fmpy: get/set rewinds an instance, and serialized bytes
restore the state in a freshly instantiated one."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2FMUstate

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


def start(slave: Slave, case: Case) -> None:
    """Initializes `slave` with the case's parameters, for a run to `N_END`."""
    slave.start(
        0.0,
        N_END * H,
        reals=case.reals,
        integers=case.integers,
        enumerations=case.enumerations,
    )


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
        start(first, case)
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


@pytest.mark.parametrize("name", list(CASES))
def test_freed_and_foreign_states_are_refused_and_unfreed_ones_go_with_the_instance(
    fmu_dir: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    case = CASES[name]
    owner = Slave(fmu_dir / case.fmu, f"{name}-owner")
    # Another extraction of the same FMU is another loaded copy of its library.
    other_copy = Slave(fmu_dir / case.fmu, f"{name}-other-copy")
    # A second instance in the owner's copy (fmpy loads the same file once).
    sibling = FMU2Slave(
        guid=owner.md.guid,
        unzipDirectory=owner._unzip_dir,
        modelIdentifier=owner.md.coSimulation.modelIdentifier,
        instanceName=f"{name}-sibling",
    )
    sibling.instantiate()
    try:
        start(owner, case)
        run(owner, case, 0, 10)
        # Left for fmi2FreeInstance: the owner's close must free them without a crash.
        kept = [owner.fmu.getFMUstate() for _ in range(3)]
        to_free = owner.fmu.getFMUstate()
        # fmi2FreeFMUstate sets the master's variable to NULL: keep a copy of the pointer.
        freed = fmi2FMUstate(to_free.value)
        owner.fmu.freeFMUstate(to_free)
        assert not to_free
        capsys.readouterr()

        # A sibling instance may restore the owner's live state, as before.
        sibling.setFMUstate(kept[0])
        assert sibling.getReal(owner.vrs(case.outputs)) == owner.fmu.getReal(
            owner.vrs(case.outputs)
        )
        # A freed state is refused, and so is a live state of another loaded copy, whose
        # table does not list it; neither pointer is read.
        with pytest.raises(FMICallException):
            other_copy.fmu.setFMUstate(kept[1])
        with pytest.raises(FMICallException):
            sibling.setFMUstate(freed)
        with pytest.raises(FMICallException):
            sibling.freeFMUstate(freed)
        printed = capsys.readouterr().out
        assert printed.count("is not a live FMU state of this FMU") == 3, printed
        # Serialized, a state does move to the other copy.
        other_copy.fmu.setFMUstate(
            other_copy.fmu.deSerializeFMUstate(owner.fmu.serializeFMUstate(kept[2]))
        )
    finally:
        sibling.fmi2FreeInstance(sibling.component)
        owner.close()
        other_copy.fmu.freeInstance()
