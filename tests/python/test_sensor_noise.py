"""Sensor noise of CkcmPlant seen through fmpy: the noise a seed gives does not depend on
the master. The orchestrator runs a closed-loop campaign with `noise_seed = { base = 1000,
per_trial = 1 }`; fmpy drives the plant open loop with seeds 1000 and 1001, and the noise
(reported minus true length and rate) must be the same at every communication point. Also
through fmpy: repeated gets agree, and get/set and serialized FMU states replay the noise.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

from master import STEP_SIZE, Slave, legs

H = STEP_SIZE
#: Steps per trial (0.3 s) and trials of the orchestrator campaign.
STEPS, TRIALS = 300, 2
SIGMA_LENGTH, SIGMA_VELOCITY = 1e-5, 1e-4
SEED_BASE = 1000
#: |noise_a − noise_b| allowed between two runs whose true values differ: (true + n) − true
#: recovers n to about one ulp of a 0.6 m length (1.1e-16) or of a rate.
ROUNDING = 1e-15
NOISE = {"length_noise_sigma": SIGMA_LENGTH, "velocity_noise_sigma": SIGMA_VELOCITY}
#: Force per leg that roughly holds the platform at home.
HOLD = 28.5315

SCENARIO = """step_size = 0.001
stop_time = 0.3
trials = {trials}
[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "line"
duration = 0.3
[[fmu]]
name = "plant"
path = "{plant}"
[fmu.parameters]
length_noise_sigma = {sl!r}
velocity_noise_sigma = {sv!r}
noise_seed = {{ base = {base}, per_trial = 1 }}
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
variables = ["plant.length", "plant.length_true", "plant.velocity", "plant.velocity_true"]
"""

OUTPUTS = legs("length") + legs("velocity") + legs("length_true") + legs("velocity_true")


def noise_of(rows: np.ndarray) -> np.ndarray:
    """Columns as in OUTPUTS -> the 12 noise channels (lengths, then rates)."""
    return rows[:, :12] - rows[:, 12:]


def fmpy_noise(plant_fmu: Path, seed: int) -> np.ndarray:
    """Noise at points 0..STEPS-1 of an open-loop fmpy run with `seed`."""
    slave = Slave(plant_fmu, f"noise-{seed}")
    try:
        slave.start(0.0, STEPS * H, reals=NOISE, integers={"noise_seed": seed})
        force, out = slave.vrs(legs("force")), slave.vrs(OUTPUTS)
        rows = [slave.fmu.getReal(out)]
        for n in range(STEPS - 1):
            slave.fmu.setReal(force, [HOLD] * 6)
            slave.fmu.doStep(n * H, H, True)
            rows.append(slave.fmu.getReal(out))
        return noise_of(np.array(rows))
    finally:
        slave.close()


def test_fmpy_sees_the_noise_of_the_orchestrator_trial_by_trial(
    fmu_dir: Path, plant_fmu: Path, orchestrator: Path, tmp_path: Path
) -> None:
    scenario = tmp_path / "noise.toml"
    scenario.write_text(
        SCENARIO.format(
            trials=TRIALS,
            controller=(fmu_dir / "HlcsController.fmu").resolve().as_posix(),
            plant=plant_fmu.resolve().as_posix(),
            sl=SIGMA_LENGTH,
            sv=SIGMA_VELOCITY,
            base=SEED_BASE,
        )
    )
    out = tmp_path / "out"
    run = subprocess.run(
        [str(orchestrator), "run", str(scenario), "--out", str(out)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.returncode == 0, f"orchestrator failed:\n{run.stdout}\n{run.stderr}"
    per_trial = []
    for k in range(TRIALS):
        path = out / "trials" / f"trial_{k:03}.csv"
        header = path.read_text().splitlines()[0].split(",")
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
        columns = [header.index(f"plant.{name}") for name in OUTPUTS]
        orchestrated = noise_of(data[:, columns])
        assert orchestrated.shape == (STEPS, 12)
        np.testing.assert_allclose(
            orchestrated, fmpy_noise(plant_fmu, SEED_BASE + k), rtol=0, atol=ROUNDING
        )
        per_trial.append(orchestrated)
    # Really noise of the stated size, and fresh in every trial.
    z = np.concatenate([n / ([SIGMA_LENGTH] * 6 + [SIGMA_VELOCITY] * 6) for n in per_trial])
    assert abs(z.std() - 1.0) < 0.05, z.std()
    assert np.abs(per_trial[0] - per_trial[1]).min() > 0.0


def test_gets_and_fmu_states_replay_the_noise(plant_fmu: Path) -> None:
    first = Slave(plant_fmu, "noise-state-first")
    out = first.vrs(OUTPUTS)
    force = first.vrs(legs("force"))

    def steps(slave: Slave, n_from: int, n_to: int) -> np.ndarray:
        rows = []
        for n in range(n_from, n_to):
            slave.fmu.setReal(force, [HOLD + 2.0 * np.sin(0.01 * n)] * 6)
            slave.fmu.doStep(n * H, H, False)
            a = slave.fmu.getReal(out)
            assert slave.fmu.getReal(out) == a, "a second get at one point differs"
            rows.append(a)
        return np.array(rows)

    try:
        first.start(0.0, 1.0, reals=NOISE, integers={"noise_seed": 77})
        steps(first, 0, 100)
        state = first.fmu.getFMUstate()
        reference = steps(first, 100, 200)
        assert np.all(noise_of(reference) != 0.0)
        first.fmu.setFMUstate(state)
        np.testing.assert_array_equal(steps(first, 100, 200), reference)
        serialized = first.fmu.serializeFMUstate(state)
        first.fmu.freeFMUstate(state)
    finally:
        first.close()
    # A fresh instance with default parameters (no noise) continues from the bytes alone,
    # noise settings and point index included.
    second = Slave(plant_fmu, "noise-state-second")
    try:
        restored = second.fmu.deSerializeFMUstate(serialized)
        second.fmu.setFMUstate(restored)
        second.fmu.freeFMUstate(restored)
        np.testing.assert_array_equal(steps(second, 100, 200), reference)
    finally:
        second.close()
