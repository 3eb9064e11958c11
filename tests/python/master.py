"""A reference co-simulation master for CkcmPlant and HlcsController, built on fmpy.

This is the wiring a reader follows to couple our two FMUs in any FMI 2.0 master. It
implements the semantics of docs/model.md §6 and nothing more:

* one macro step of h = 1 ms, with t_n = t0 + n·h computed from n (never accumulated);
* Gauss–Seidel order with no added delay: controller first (it sees the plant outputs
  at t_n), then the plant (it sees the force the controller just produced);
* the iteration memory ("LSI RAM"): the controller reads u_k(t_n) from a read buffer and
  returns u_{k+1}(t_n) as `memory_next`, which goes into a write buffer; at the end of a
  trial the write buffer becomes the read buffer. Trial 0 reads zeros.
* optionally, the robust memory update of docs/model.md §9 between trials
  (`MemoryUpdate`, applied with scipy): u_{k+1} = Q[α·u_k + g·shift_δ(m_k − u_k)].

Use it as a library (``run_trials``) or as a script::

    python master.py --trajectory line --trials 3
"""

from __future__ import annotations

import argparse
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.model_description import ModelDescription
from fmpy.fmi2 import FMU2Slave
from scipy import signal

#: Communication step (s): the controller's sample period and DefaultExperiment stepSize.
STEP_SIZE = 1e-3

#: The paper's durations (s) of each trajectory.
DURATION = {"hold": 1.0, "line": 15.0, "circle": 5.0}

#: Integral learning gain Ψ of HLCS (Table 1); PD-type learning is Ψ = 0.
PSI_HLCS = 7.5

LEGS = 6


def legs(name: str) -> list[str]:
    """The six scalar names of an array variable: `force` -> `force[1]` ... `force[6]`."""
    return [f"{name}[{i}]" for i in range(1, LEGS + 1)]


def enumeration_value(md: ModelDescription, variable: str, item: str) -> int:
    """The value of `item` in the enumeration type of `variable`, read from the model
    description, so renumbering an item in the XML needs no edit here."""
    var = next((v for v in md.modelVariables if v.name == variable), None)
    if var is None:
        raise KeyError(f"{md.modelName} has no variable {variable!r}")
    declared = var.declaredType
    if var.type != "Enumeration" or declared is None:
        raise KeyError(f"{md.modelName}: {variable!r} is not an enumeration variable")
    values = {i.name: int(i.value) for i in declared.items}
    if item not in values:
        raise KeyError(
            f"{md.modelName}: {item!r} is not an item of {declared.name} (items: {values})"
        )
    return values[item]


def default_fmu_dir() -> Path:
    """Where the packaged FMUs are: `$CKCM_FMU_DIR`, else `<repo>/target/fmu`."""
    env = os.environ.get("CKCM_FMU_DIR")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "target" / "fmu"


@dataclass(frozen=True)
class MemoryUpdate:
    """The between-trial update of one memory channel (docs/model.md §9), the same keys as a
    scenario's `[memory.update]` table:

        u_{k+1} = Q[ forgetting·u_k + gain·shift_lead(m_k − u_k) ]

    with u_k the memory read during trial k and m_k the `memory_next` written during it;
    shift_lead(Δ)(n) = Δ(n + lead), the last `lead` samples repeating Δ(N − 1); Q, when
    `filter` is "butterworth", is `filtfilt(b, a, ·, axis=0, method="gust")` with
    `b, a = butter(order, cutoff, fs=1/h)`.
    """

    filter: str | None = None
    order: int | None = None
    cutoff: float | None = None  # Hz
    lead: int = 0  # samples
    forgetting: float = 1.0
    gain: float = 1.0

    def is_identity(self) -> bool:
        """The paper's update: m_k becomes u_{k+1} unchanged."""
        return self.filter is None and self.lead == 0 and self.forgetting == 1.0 and self.gain == 1.0

    def apply(self, u: np.ndarray, m: np.ndarray, step_size: float) -> np.ndarray:
        """u_{k+1} from u_k and m_k (arrays of samples × elements)."""
        if self.is_identity():
            return m
        delta = m - u
        if self.lead:
            tail = np.repeat(delta[-1:], self.lead, axis=0)
            delta = np.concatenate((delta[self.lead :], tail))
        x = self.forgetting * u + self.gain * delta
        if self.filter is not None:
            if self.filter != "butterworth":
                raise ValueError(f"unknown memory filter {self.filter!r}")
            b, a = signal.butter(self.order, self.cutoff, fs=1 / step_size)
            x = signal.filtfilt(b, a, x, axis=0, method="gust")
        return x


#: The robust setting of scenarios/*-robust.toml.
ROBUST = MemoryUpdate(filter="butterworth", order=4, cutoff=8.0, lead=25)


class Slave:
    """One FMU, extracted and instantiated once, with value references looked up by name.

    The master talks to the FMU only through fmpy's `FMU2Slave`; fmpy raises on any call
    that returns fmi2Error or worse, so a failed call cannot go unnoticed.
    """

    def __init__(self, fmu_path: Path, instance_name: str) -> None:
        if not fmu_path.is_file():
            raise FileNotFoundError(
                f"{fmu_path} not found: build it with `cargo xtask fmu` "
                "or point CKCM_FMU_DIR at the directory holding it"
            )
        self.path = fmu_path
        md = read_model_description(str(fmu_path))
        self.md = md
        self._vr = {v.name: v.valueReference for v in md.modelVariables}
        self._unzip_dir = extract(str(fmu_path))
        self.fmu = FMU2Slave(
            guid=md.guid,
            unzipDirectory=self._unzip_dir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=instance_name,
        )
        self.fmu.instantiate()
        self._initialized_once = False

    def vrs(self, names: list[str]) -> list[int]:
        """Value references of `names`; a `KeyError` names any variable the FMU lacks."""
        return [self._vr[n] for n in names]

    def start(
        self,
        start_time: float,
        stop_time: float,
        reals: dict[str, float] | None = None,
        integers: dict[str, int] | None = None,
        booleans: dict[str, bool] | None = None,
        enumerations: dict[str, str] | None = None,
    ) -> None:
        """Brings the instance to a fresh initial state, ready for `doStep(start_time, h)`.

        Every trial must start from the same state (the ILC repeatability assumption), so
        from the second call on the instance is reset first. fmi2Reset restores the start
        values, so the parameters are set again every time. `enumerations` maps a variable
        to an item name, whose value comes from the model description.
        """
        if self._initialized_once:
            self.fmu.reset()
        if enumerations:
            integers = dict(integers or {})
            for variable, item in enumerations.items():
                integers[variable] = enumeration_value(self.md, variable, item)
        for values, setter in (
            (reals, self.fmu.setReal),
            (integers, self.fmu.setInteger),
            (booleans, self.fmu.setBoolean),
        ):
            if values:
                setter(self.vrs(list(values)), list(values.values()))
        self.fmu.setupExperiment(startTime=start_time, stopTime=stop_time)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self._initialized_once = True

    def close(self) -> None:
        """Terminates and frees the instance and removes the extracted files."""
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self._unzip_dir, ignore_errors=True)


@dataclass
class Trial:
    """Signals of one trial, one row per sample n (all arrays are N×6 except `time`).

    Row n holds the plant outputs at t_n (the controller's inputs for sample n) and the
    controller outputs of sample n (held by the plant over [t_n, t_{n+1}]).
    """

    time: np.ndarray
    length: np.ndarray
    velocity: np.ndarray
    force: np.ndarray
    memory_next: np.ndarray
    error: np.ndarray
    pose: np.ndarray
    #: u_{k+1}: the memory this trial leaves for the next, after the update.
    memory: np.ndarray


class HlcsMaster:
    """The closed loop CkcmPlant ↔ HlcsController with an iteration memory."""

    def __init__(
        self,
        fmu_dir: Path,
        trajectory: str = "line",
        duration: float | None = None,
        learning: bool = True,
        psi: float = PSI_HLCS,
        step_size: float = STEP_SIZE,
        start_time: float = 0.0,
        update: MemoryUpdate | None = None,
    ) -> None:
        self.h = step_size
        self.update = MemoryUpdate() if update is None else update
        self.t0 = start_time
        self.duration = DURATION[trajectory] if duration is None else duration
        self.stop_time = start_time + self.duration
        self.steps = round(self.duration / step_size)
        self.controller_parameters = {
            "reals": {"duration": self.duration, "psi": psi},
            "enumerations": {"trajectory": trajectory},
            "booleans": {"learning": learning},
        }
        self.controller = Slave(fmu_dir / "HlcsController.fmu", "controller")
        self.plant = Slave(fmu_dir / "CkcmPlant.fmu", "plant")
        # Value references, looked up once by name. The controller's inputs and outputs
        # are each moved in one call, in this order.
        self.c_in = self.controller.vrs(legs("length") + legs("velocity") + legs("memory"))
        self.c_out = self.controller.vrs(legs("force") + legs("memory_next") + legs("error"))
        self.p_in = self.plant.vrs(legs("force"))
        self.p_out = self.plant.vrs(legs("length") + legs("velocity"))
        self.p_pose = self.plant.vrs(legs("pose"))
        # The iteration memory u_k(t_n): row n of the read buffer feeds sample n.
        self.memory = np.zeros((self.steps, LEGS))

    def time(self, n: int) -> float:
        """t_n = t0 + n·h, computed from n so rounding never accumulates."""
        return self.t0 + n * self.h

    def run_trial(self) -> Trial:
        """Runs one trial from the initial state with the current memory, then makes the
        memory it wrote the memory of the next trial."""
        n_steps, h = self.steps, self.h
        rows = {
            k: np.empty((n_steps, LEGS))
            for k in ("length", "velocity", "force", "error", "pose")
        }
        write = np.empty((n_steps, LEGS))  # u_{k+1}(t_n), the write buffer

        # Both FMUs start every trial from the same initial state.
        self.controller.start(self.t0, self.stop_time, **self.controller_parameters)
        self.plant.start(self.t0, self.stop_time)
        # Plant outputs at t_0 (after initialization).
        y = self.plant.fmu.getReal(self.p_out)

        for n in range(n_steps):
            t = self.time(n)
            rows["length"][n] = y[:LEGS]
            rows["velocity"][n] = y[LEGS:]
            rows["pose"][n] = self.plant.fmu.getReal(self.p_pose)

            # (1) Controller inputs: plant outputs at t_n and u_k(t_n) from the read buffer.
            self.controller.fmu.setReal(self.c_in, [*y, *self.memory[n]])
            # (2) The controller samples at t_n; its outputs are held over [t_n, t_{n+1}].
            self.controller.fmu.doStep(t, h)
            u = self.controller.fmu.getReal(self.c_out)
            force = u[:LEGS]
            rows["force"][n] = force
            write[n] = u[LEGS : 2 * LEGS]  # u_{k+1}(t_n) into the write buffer
            rows["error"][n] = u[2 * LEGS :]

            # (3) The plant integrates over [t_n, t_{n+1}] under the force just computed
            # (Gauss–Seidel: no delay), then its outputs are those at t_{n+1}.
            self.plant.fmu.setReal(self.p_in, force)
            self.plant.fmu.doStep(t, h)
            y = self.plant.fmu.getReal(self.p_out)

        # End of trial: the update makes u_{k+1} from u_k and the written m_k; it becomes
        # the read buffer (the paper's update: the write buffer itself).
        self.memory = self.update.apply(self.memory, write, h)
        return Trial(
            time=self.t0 + np.arange(n_steps) * h,
            memory_next=write.copy(),
            memory=self.memory.copy(),
            **rows,
        )

    def close(self) -> None:
        """Frees both instances."""
        self.controller.close()
        self.plant.close()


def run_trials(
    fmu_dir: Path | None = None,
    trajectory: str = "line",
    trials: int = 3,
    duration: float | None = None,
    learning: bool = True,
    psi: float = PSI_HLCS,
    update: MemoryUpdate | None = None,
) -> list[Trial]:
    """Runs `trials` consecutive trials (trial 0 with zero memory) and returns each one's
    signals. The FMUs are instantiated once and reset between trials."""
    master = HlcsMaster(
        default_fmu_dir() if fmu_dir is None else fmu_dir,
        trajectory=trajectory,
        duration=duration,
        learning=learning,
        psi=psi,
        update=update,
    )
    try:
        return [master.run_trial() for _ in range(trials)]
    finally:
        master.close()


def main() -> None:
    """Command line: run trials and print each one's maximum leg error."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--trajectory", choices=["hold", "line", "circle"], default="line")
    parser.add_argument("--trials", type=int, default=3)
    parser.add_argument("--duration", type=float, help="s (default: line 15, circle 5)")
    parser.add_argument(
        "--scheme",
        choices=["hlcs", "pd-ilc", "pid"],
        default="hlcs",
        help="hlcs: PID-type learning; pd-ilc: Psi = 0; pid: learning off",
    )
    parser.add_argument(
        "--robust",
        action="store_true",
        help="robust memory update: Butterworth order 4, 8 Hz, lead 25 (docs/model.md §9)",
    )
    parser.add_argument("--fmu-dir", type=Path, default=default_fmu_dir())
    args = parser.parse_args()

    started = time.perf_counter()
    results = run_trials(
        args.fmu_dir,
        trajectory=args.trajectory,
        trials=args.trials,
        duration=args.duration,
        learning=args.scheme != "pid",
        psi=0.0 if args.scheme == "pd-ilc" else PSI_HLCS,
        update=ROBUST if args.robust else None,
    )
    elapsed = time.perf_counter() - started
    for k, trial in enumerate(results):
        print(f"trial {k}: max |e| = {np.abs(trial.error).max() * 1e3:.4f} mm")
    print(f"{len(results)} trials in {elapsed:.2f} s")


if __name__ == "__main__":
    main()
