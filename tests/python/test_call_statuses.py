"""Every FMI call fmpy makes on a full plant run returns fmi2OK (not even a warning), and
the one warning the plant has, a stiff adaptive integration, reaches fmpy once."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from fmpy import read_model_description, simulate_fmu

from master import enumeration_value, legs

#: fmpy logs `fmi2DoStep(...) -> OK`; other tools write `-> fmi2OK`. Calls returning a
#: pointer log `-> 0x...` and void calls log no arrow, so neither matches.
STATUS = re.compile(
    r"^(fmi2\w+)\(.*\)\s*->\s*(?:fmi2)?(OK|Warning|Discard|Error|Fatal|Pending|\d+)\s*$",
    re.IGNORECASE | re.DOTALL,
)
OK = {"ok", "0"}


def test_every_call_of_a_plant_run_returns_ok(plant_fmu: Path) -> None:
    log: list[str] = []
    simulate_fmu(
        str(plant_fmu),
        fmi_type="CoSimulation",
        output_interval=1e-3,
        stop_time=2.0,
        start_values={name: 28.5315 for name in legs("force")},
        fmi_call_logger=log.append,
    )
    calls = [(line, m.group(1), m.group(2)) for line in log if (m := STATUS.match(line))]
    # 2000 doSteps plus 2000 getReal calls at least: the check cannot pass on an empty log.
    assert len(calls) > 2000, f"only {len(calls)} of {len(log)} log lines had a status"
    assert sum(function == "fmi2DoStep" for _, function, _ in calls) == 2000
    not_ok = [line for line, _, status in calls if status.lower() not in OK]
    assert not not_ok, f"{len(not_ok)} calls did not return fmi2OK, e.g. {not_ok[:5]}"


def test_status_parser_reads_both_spellings_and_skips_calls_without_status() -> None:
    parsed = {
        line: (m.group(1), m.group(2)) if (m := STATUS.match(line)) else None
        for line in [
            "fmi2DoStep(c=0x1, currentCommunicationPoint=0.0) -> OK",
            "fmi2GetReal(c=0x1, vr=[1, 2], nvr=2, value=[0.5, (1)]) -> fmi2Warning",
            "fmi2SetReal(c=0x1) -> 3",
            'fmi2Instantiate(instanceName="p") -> 0x55b571d83480',
            "fmi2FreeInstance(c=0x1)",
        ]
    }
    assert list(parsed.values()) == [
        ("fmi2DoStep", "OK"),
        ("fmi2GetReal", "Warning"),
        ("fmi2SetReal", "3"),
        None,
        None,
    ]


def test_a_stiff_plant_step_returns_a_warning_once_and_the_run_goes_on(
    plant_fmu: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """At the smallest friction_velocity the adaptive integrator needs thousands of steps per
    1 ms interval: the plant's first doStep returns fmi2Warning with a message saying why, the
    later ones fmi2OK, and fmpy runs to the stop time."""
    md = read_model_description(str(plant_fmu))
    force = {name: 28.531475275310612 for name in legs("force")}
    force["force[1]"] += 1.5  # below the Coulomb friction: leg 1 creeps, its rate near zero
    calls: list[str] = []
    capsys.readouterr()
    # The messages are read from what fmpy's own logger prints. simulate_fmu's `logger`
    # argument would leave fmpy's logging shim calling that callback after the run has
    # freed it, and the next FMU that logs in this process would crash.
    result = simulate_fmu(
        str(plant_fmu),
        fmi_type="CoSimulation",
        output_interval=1e-3,
        stop_time=0.004,
        start_values={
            **force,
            "integrator": enumeration_value(md, "integrator", "dormand_prince"),
            "friction_velocity": 1e-6,
        },
        debug_logging=True,
        fmi_call_logger=calls.append,
    )
    assert result["time"][-1] == pytest.approx(0.004)
    steps = [
        m.group(2).lower()
        for line in calls
        if (m := STATUS.match(line)) and m.group(1) == "fmi2DoStep"
    ]
    assert steps == ["warning", "ok", "ok", "ok"], steps
    printed = capsys.readouterr().out
    warnings = [line for line in printed.splitlines() if line.startswith("[WARNING]")]
    assert len(warnings) == 1, printed
    assert "fmi2DoStep: step from 0 by 0.001 taken: the adaptive integrator took" in warnings[0]
    assert "friction_velocity" in warnings[0]


#: Runs in its own interpreter: before components were handles, the made-up one crashed it.
STALE_CALLS = """
import sys
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2Real, fmi2True, fmi2ValueReference

fmu = sys.argv[1]
md = read_model_description(fmu)
folder = extract(fmu)
def slave(name):
    s = FMU2Slave(guid=md.guid, unzipDirectory=folder,
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
    s.instantiate()
    return s
freed, live = slave("freed"), slave("live")
stale = freed.component
freed.freeInstance()  # the library stays loaded: `live` holds it too
vr = (md.modelVariables[0].valueReference,)
calls = {
    "fmi2DoStep": lambda c: live.fmi2DoStep(c, 0.0, 1e-3, fmi2True),
    "fmi2SetupExperiment": lambda c: live.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0),
    "fmi2GetReal": lambda c: live.fmi2GetReal(
        c, (fmi2ValueReference * 1)(*vr), 1, (fmi2Real * 1)()),
    "fmi2Reset": lambda c: live.fmi2Reset(c),
}
for component in (stale, 0x10, 0x7FFF_0000_1230):
    for name, call in calls.items():
        try:
            call(component)
            print(f"{name}({component:#x}) returned OK")
        except FMICallException as e:
            print(f"{name}({component:#x}) -> {e.status}")
    live.fmi2FreeInstance(component)  # not an instance: nothing happens
live.setupExperiment(startTime=0.0)
live.enterInitializationMode()
live.exitInitializationMode()
for k in range(3):
    live.doStep(currentCommunicationPoint=k * 1e-3, communicationStepSize=1e-3)
print("live instance stepped to", live.getReal(vr))
live.terminate()
live.freeInstance()
"""


@pytest.mark.parametrize("which", ["plant", "controller"])
def test_a_freed_or_made_up_component_gets_an_error_not_a_crash(
    which: str, plant_fmu: Path, controller_fmu: Path
) -> None:
    """fmpy calls an FMU with the component of an instance it freed and with two made-up
    pointers: each call returns fmi2Error (3), and the other instance of the same library
    runs on."""
    import subprocess
    import sys

    fmu = plant_fmu if which == "plant" else controller_fmu
    run = subprocess.run(
        [sys.executable, "-c", STALE_CALLS, str(fmu)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, f"exit {run.returncode}: {run.stdout}\n{run.stderr}"
    lines = run.stdout.splitlines()
    refused = [line for line in lines if line.endswith(" -> 3")]
    assert len(refused) == 12, lines
    assert not any("returned OK" in line for line in lines), lines
    assert lines[-1].startswith("live instance stepped to"), lines
