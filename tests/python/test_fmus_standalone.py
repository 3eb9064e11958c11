"""Each FMU on its own under fmpy (issue 3): validation, the plant under hold and zero
forces, and the controller's output computed by hand."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

from master import enumeration_value, legs

#: Static force per leg that holds the plant at home (docs/model.md §3).
HOLD_FORCE = 28.5315
#: Nominal-model (no rod) static force per leg at home at rest: the controller's
#: feedforward τ_a there (docs/model.md §3, 18.0647 N).
TAU_A_HOME = 18.0646612
#: Every leg's length at the home pose (m).
HOME_LENGTH = 0.5667144462950593
#: Table 1 gains used by the controller's defaults.
KP, KI, KD = 50000.0, 10.0, 850.0
H = 1e-3


@pytest.mark.parametrize("name", ["CkcmPlant.fmu", "HlcsController.fmu"])
def test_fmpy_validate_reports_no_problems(fmu_dir: Path, name: str) -> None:
    # `fmpy validate` exits with the number of problems it found.
    run = subprocess.run(
        [sys.executable, "-m", "fmpy", "validate", str(fmu_dir / name)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, f"fmpy validate {name}:\n{run.stdout}{run.stderr}"
    assert "No problems found." in run.stdout


def simulate_plant(
    plant_fmu: Path,
    force: float,
    messages: list[tuple[int, str]] | None = None,
    **parameters: int | float,
) -> np.ndarray:
    """2 s of the plant under a constant force on every leg, with extra parameters. Its log
    messages go to `messages` when given; otherwise any problem it logs fails the test."""
    expected = messages is not None
    messages = [] if messages is None else messages
    result = simulate_fmu(
        str(plant_fmu),
        fmi_type="CoSimulation",
        output_interval=1e-3,
        stop_time=2.0,
        start_values={**{name: force for name in legs("force")}, **parameters},
        output=legs("pose") + legs("velocity"),
        logger=lambda _c, _n, status, _cat, msg: messages.append((status, msg.decode())),
    )
    if not expected:
        assert not [m for m in messages if m[0] > 0], f"plant logged problems: {messages}"
    return result


def test_plant_holds_home_under_static_forces(plant_fmu: Path) -> None:
    result = simulate_plant(plant_fmu, HOLD_FORCE)
    assert len(result) == 2001
    position = np.column_stack([result[f"pose[{i}]"] for i in (1, 2, 3)])
    np.testing.assert_allclose(position, np.tile([0.0, 0.0, 0.5], (len(result), 1)), atol=1e-4)


def test_plant_holds_home_at_fmpy_default_step_sizes(plant_fmu: Path) -> None:
    """A master stepping at 10 or 16 ms (fmpy's own choice for a 16 s run without
    `output_interval`) gets 1 ms RK4 substeps (`rk4_max_step`): one RK4 step that long
    drifts off home by centimetres and, at 16 ms, hits the stroke end."""
    for interval in (0.01, 0.016):
        result = simulate_fmu(
            str(plant_fmu),
            fmi_type="CoSimulation",
            output_interval=interval,
            stop_time=16.0,
            start_values={name: HOLD_FORCE for name in legs("force")},
            output=legs("pose"),
        )
        assert result["time"][-1] == pytest.approx(16.0, abs=1e-9), interval
        # 28.5315 N is the static force to 6 digits: the platform creeps by under 1e-6 m
        # in 16 s, against centimetres for one RK4 step per interval.
        z = result["pose[3]"]
        assert np.max(np.abs(z - 0.5)) < 1e-5, f"{interval} s steps: z reached {z.max()} m"


def test_plant_falls_without_forces(plant_fmu: Path) -> None:
    """The platform falls until a leg leaves its stroke; fmpy stops there, and although it
    leaves debug logging off, the plant's logger call says why (fmi2Discard, category
    logStatusDiscard: on from instantiation)."""
    messages: list[tuple[int, str]] = []
    result = simulate_plant(plant_fmu, 0.0, messages)
    z = result["pose[3]"]
    assert z[0] == pytest.approx(0.5, abs=1e-12)
    assert z[-1] < z[0] - 1e-2, f"z went from {z[0]} to {z[-1]} m under zero forces"
    assert np.all(np.diff(z[:100]) <= 0.0), "z must decrease from rest"
    assert 0.5 < result["time"][-1] < 2.0, result["time"][-1]
    problems = [m for m in messages if m[0] > 0]
    assert len(problems) == 1 and problems[0][0] == 2, messages  # 2: fmi2Discard
    assert "fmi2DoStep" in problems[0][1] and "outside its stroke" in problems[0][1], problems


def test_controller_alone_matches_hand_computed_pid_and_feedforward(
    controller_fmu: Path,
) -> None:
    # Constant inputs: leg 1 1 mm too long, leg 2 extending at 10 mm/s, 5 N of memory
    # on leg 3; the reference (line, at rest at home for t <= h) is l_d = home, l̇_d = 0.
    dl, v, mem = 1e-3, 0.01, 5.0
    result = simulate_fmu(
        str(controller_fmu),
        fmi_type="CoSimulation",
        output_interval=H,
        stop_time=2 * H,
        start_values={
            "trajectory": enumeration_value(
                read_model_description(str(controller_fmu)), "trajectory", "line"
            ),
            "length[1]": HOME_LENGTH + dl,
            "velocity[2]": v,
            "memory[3]": mem,
        },
        output=legs("force") + legs("error"),
    )
    force = np.column_stack([result[n] for n in legs("force")])
    error = np.column_stack([result[n] for n in legs("error")])
    np.testing.assert_allclose(result["time"][:2], [0.0, H], atol=1e-15)

    # e = l_d − l and ė = l̇_d − l̇, by hand.
    e = np.array([HOME_LENGTH - (HOME_LENGTH + dl), 0, 0, 0, 0, 0])
    e_dot = np.array([0, -v, 0, 0, 0, 0])
    memory = np.array([0, 0, mem, 0, 0, 0])
    np.testing.assert_allclose(error[0], e, rtol=0, atol=1e-12)
    np.testing.assert_allclose(error[1], e, rtol=0, atol=1e-12)

    # At t = 0 (after initialization) the integral is still zero.
    at_init = KP * e + KD * e_dot + memory + TAU_A_HOME
    np.testing.assert_allclose(force[0], at_init, rtol=0, atol=1e-6)
    # The same numbers spelled out: Kp·(−1 mm) = −50 N, Kd·(−10 mm/s) = −8.5 N, 5 N memory.
    np.testing.assert_allclose(
        force[0], np.array([-50.0, -8.5, 5.0, 0, 0, 0]) + TAU_A_HOME, rtol=0, atol=1e-6
    )

    # After the first step (the output held over [0, h]) the integral is e·h.
    np.testing.assert_allclose(force[1], at_init + KI * e * H, rtol=0, atol=1e-7)
    assert force[1, 0] - force[0, 0] == pytest.approx(KI * -dl * H, abs=1e-9)


def test_friction_curve_is_tanh_by_default_and_algebraic_on_request(plant_fmu: Path) -> None:
    """`friction_curve` set from fmpy: the default is the tanh curve bit for bit; the
    algebraic curve changes the motion a little (it saturates more slowly, so it brakes the
    falling legs less) but not the character of it."""
    md = read_model_description(str(plant_fmu))
    force = 0.8 * HOLD_FORCE
    default = simulate_plant(plant_fmu, force)
    tanh = simulate_plant(
        plant_fmu, force, friction_curve=enumeration_value(md, "friction_curve", "tanh")
    )
    algebraic = simulate_plant(
        plant_fmu, force, friction_curve=enumeration_value(md, "friction_curve", "algebraic")
    )
    names = legs("pose") + legs("velocity")
    for name in names:
        np.testing.assert_array_equal(default[name], tanh[name], err_msg=name)
    z_tanh, z_algebraic = tanh["pose[3]"], algebraic["pose[3]"]
    assert z_tanh[-1] < 0.5 - 1e-3, "the platform sinks under 80 % of the holding force"
    gap = np.max(np.abs(z_algebraic - z_tanh))
    assert 1e-7 < gap < 0.1 * (0.5 - z_tanh[-1]), f"curves differ by {gap} m in z"
