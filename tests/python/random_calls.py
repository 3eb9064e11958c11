"""Random FMI 2.0 call sequences against one FMU's shared library, through ctypes.

Run as its own process (a crash must not take pytest down):

    python tests/python/random_calls.py FMU SEED SEQUENCES

Each sequence instantiates (now and then with a foreign GUID, a wrong FMU type or a bad
resource location), usually walks the legal path into stepping, and then makes random
calls: every function of the co-simulation interface, in any order, with unknown value
references, NULL arrays, NaN and infinite values, wrong communication points, and
serialized states that were cut short or had bytes flipped. The last line printed is a JSON
summary; the test reads it. The process must exit 0: a segmentation fault or an abort is a
failure of the FMU, whatever the calls were.

ctypes rather than fmpy's `FMU2Slave`: fmpy raises on every error status and checks some
arguments itself, so the calls that matter here would not all reach the library.
"""

from __future__ import annotations

import json
import random
import sys
import tempfile
import zipfile
from ctypes import (
    CDLL,
    POINTER,
    byref,
    c_char_p,
    c_double,
    c_int,
    c_size_t,
    c_uint,
    c_void_p,
    create_string_buffer,
)
from pathlib import Path

from fmpy import read_model_description
from fmpy.fmi2 import (
    calloc,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2StepFinishedTYPE,
    free,
)

#: fmi2CoSimulation of `fmi2Type`.
CO_SIMULATION = 1


class Library:
    """The FMU's functions with their C signatures; every status they return is counted."""

    def __init__(self, path: Path) -> None:
        self.lib = CDLL(str(path))
        self.statuses: dict[str, dict[int, int]] = {}
        #: The status of the latest call.
        self.last = 0
        p, i, d, n = c_void_p, c_int, c_double, c_size_t
        self.sig = {
            "fmi2SetupExperiment": [p, i, d, d, i, d],
            "fmi2EnterInitializationMode": [p],
            "fmi2ExitInitializationMode": [p],
            "fmi2Terminate": [p],
            "fmi2Reset": [p],
            "fmi2GetReal": [p, p, n, p],
            "fmi2SetReal": [p, p, n, p],
            "fmi2GetInteger": [p, p, n, p],
            "fmi2SetInteger": [p, p, n, p],
            "fmi2GetBoolean": [p, p, n, p],
            "fmi2SetBoolean": [p, p, n, p],
            "fmi2GetString": [p, p, n, p],
            "fmi2SetString": [p, p, n, p],
            "fmi2DoStep": [p, d, d, i],
            "fmi2CancelStep": [p],
            "fmi2GetFMUstate": [p, p],
            "fmi2SetFMUstate": [p, p],
            "fmi2FreeFMUstate": [p, p],
            "fmi2SerializedFMUstateSize": [p, p, p],
            "fmi2SerializeFMUstate": [p, p, p, n],
            "fmi2DeSerializeFMUstate": [p, p, n, p],
            "fmi2GetStatus": [p, i, p],
            "fmi2GetRealStatus": [p, i, p],
            "fmi2GetIntegerStatus": [p, i, p],
            "fmi2GetBooleanStatus": [p, i, p],
            "fmi2GetStringStatus": [p, i, p],
            "fmi2SetDebugLogging": [p, i, n, p],
            "fmi2GetDirectionalDerivative": [p, p, n, p, n, p, p],
            "fmi2SetRealInputDerivatives": [p, p, n, p, p],
            "fmi2GetRealOutputDerivatives": [p, p, n, p, p],
        }
        for name, args in self.sig.items():
            f = getattr(self.lib, name)
            f.restype, f.argtypes = c_int, args
        self.instantiate = self.lib.fmi2Instantiate
        self.instantiate.restype = c_void_p
        self.instantiate.argtypes = [
            c_char_p,
            c_int,
            c_char_p,
            c_char_p,
            POINTER(fmi2CallbackFunctions),
            c_int,
            c_int,
        ]
        self.free_instance = self.lib.fmi2FreeInstance
        self.free_instance.restype, self.free_instance.argtypes = None, [c_void_p]

    def __call__(self, name: str, *args) -> int:
        status = getattr(self.lib, name)(*args)
        self.last = status
        counts = self.statuses.setdefault(name, {})
        counts[status] = counts.get(status, 0) + 1
        return status


def array(ctype, values: list):
    """A C array of `values` (one element at least, so the pointer is never NULL)."""
    return (ctype * max(1, len(values)))(*values)


def main(fmu: Path, unpacked: Path, seed: int, sequences: int) -> dict:
    """The summary of `sequences` random sequences on `fmu`, unpacked into `unpacked`."""
    rng = random.Random(seed)
    md = read_model_description(str(fmu))
    with zipfile.ZipFile(fmu) as z:
        z.extractall(unpacked)
    lib = Library(unpacked / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so")
    resources = ("file://" + str(unpacked / "resources")).encode()
    by_type: dict[str, list[int]] = {}
    for v in md.modelVariables:
        kind = "Integer" if v.type == "Enumeration" else v.type
        by_type.setdefault(kind, []).append(v.valueReference)
    inputs = [
        v.valueReference for v in md.modelVariables if v.type == "Real" and v.causality == "input"
    ]

    null_messages = 0

    def log(_env, _name, _status, _category, message) -> None:
        nonlocal null_messages
        null_messages += message is None

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(log)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    callbacks.stepFinished = fmi2StepFinishedTYPE()
    callbacks.componentEnvironment = None

    def number() -> float:
        return rng.choice(
            [
                0.0,
                -0.0,
                1.0,
                -1.0,
                1e-3,
                0.5,
                0.7,
                15.0,
                1e300,
                -1e300,
                5e-324,
                float("nan"),
                float("inf"),
                -float("inf"),
                rng.uniform(-100.0, 100.0),
            ]
        )

    def references(kind: str) -> list[int]:
        pool = by_type.get(kind, [])
        n = rng.choice([0, 1, 2, 6, 18, rng.randint(0, 40)])
        return [
            rng.choice(pool)
            if pool and rng.random() < 0.85
            else rng.choice([999_999, 2**32 - 1, rng.randint(0, 300)])
            for _ in range(n)
        ]

    summary = {
        "instances": 0,
        "legal_steps": 0,
        "foreign_guid_accepted": 0,
        "wrong_type_accepted": 0,
    }

    def start_stepping(c: int) -> float:
        """The legal path into stepping and a few steps; the time reached."""
        lib("fmi2SetupExperiment", c, 0, 0.0, 0.0, 1, 15.0)
        lib("fmi2EnterInitializationMode", c)
        lib("fmi2ExitInitializationMode", c)
        time = 0.0
        for _ in range(rng.choice([0, 5, 50])):
            if lib("fmi2DoStep", c, time, 1e-3, 1) == 0:
                time += 1e-3
                summary["legal_steps"] += 1
        return time

    for _ in range(sequences):
        guid_ok = rng.random() < 0.95
        kind = rng.choice([CO_SIMULATION] * 4 + [0, 7])
        c = lib.instantiate(
            b"random",
            kind,
            md.guid.encode() if guid_ok else b"{00000000-0000-0000-0000-000000000000}",
            resources if rng.random() < 0.9 else rng.choice([b"", b"file:///nonexistent", None]),
            byref(callbacks),
            0,
            rng.choice([0, 1]),
        )
        if not c:
            continue
        summary["foreign_guid_accepted"] += not guid_ok
        summary["wrong_type_accepted"] += kind != CO_SIMULATION
        summary["instances"] += 1
        states: list[c_void_p] = []

        t = start_stepping(c) if rng.random() < 0.7 else 0.0
        for _ in range(rng.randint(1, 60)):
            # After an error only fmi2Reset (or freeing) is allowed: mostly recover, so the
            # calls that follow meet a live instance.
            if lib.last >= 3 and rng.random() < 0.7 and lib("fmi2Reset", c) == 0:
                t = start_stepping(c)
            null = rng.random() < 0.05
            op = rng.randrange(21)
            if op == 0:
                lib(
                    "fmi2SetupExperiment",
                    c,
                    rng.choice([0, 1]),
                    number(),
                    rng.choice([0.0, 0.0, number()]),
                    rng.choice([0, 1]),
                    rng.choice([15.0, number()]),
                )
            elif op == 1:
                lib(
                    rng.choice(
                        [
                            "fmi2EnterInitializationMode",
                            "fmi2ExitInitializationMode",
                            "fmi2Terminate",
                            "fmi2Reset",
                            "fmi2CancelStep",
                        ]
                    ),
                    c,
                )
            elif op in (2, 3):
                vrs = references("Real")
                n = rng.choice([0, 3]) if null else len(vrs)
                vr_arg = None if null and rng.random() < 0.5 else array(c_uint, vrs)
                if op == 2 and rng.random() < 0.5:
                    # A plausible set: inputs only, finite values.
                    vrs = rng.sample(inputs, rng.randint(1, len(inputs)))
                    values = [rng.uniform(-50.0, 50.0) for _ in vrs]
                    lib("fmi2SetReal", c, array(c_uint, vrs), len(vrs), array(c_double, values))
                elif op == 2:
                    lib(
                        "fmi2SetReal",
                        c,
                        vr_arg,
                        n,
                        None if null else array(c_double, [number() for _ in vrs]),
                    )
                else:
                    lib(
                        "fmi2GetReal",
                        c,
                        vr_arg,
                        n,
                        None if null else array(c_double, [0.0] * len(vrs)),
                    )
            elif op in (4, 5):
                # Integer and Boolean values travel as C ints alike.
                kind, choices = (
                    ("Integer", [0, 1, 2, 5, -1, 2**31 - 1, -(2**31)])
                    if op == 4
                    else ("Boolean", [0, 1, 2, -5])
                )
                vrs = references(kind)
                values = [rng.choice(choices) for _ in vrs]
                lib(
                    rng.choice([f"fmi2Set{kind}", f"fmi2Get{kind}"]),
                    c,
                    array(c_uint, vrs),
                    len(vrs),
                    array(c_int, values),
                )
            elif op == 6:
                vrs = references("String")
                texts = [
                    rng.choice([b"line", b"circle", b"", b"\xff\xfe", b"x" * 5000, None])
                    for _ in vrs
                ]
                lib("fmi2SetString", c, array(c_uint, vrs), len(vrs), array(c_char_p, texts))
            elif op == 7:
                vrs = references("String")
                lib(
                    "fmi2GetString",
                    c,
                    array(c_uint, vrs),
                    len(vrs),
                    array(c_char_p, [None] * len(vrs)),
                )
            elif op in (8, 9, 10):
                h = rng.choice([1e-3, 1e-3, 1e-3, number()])
                point = t if rng.random() < 0.9 else number()
                if lib("fmi2DoStep", c, point, h, rng.choice([0, 1])) == 0:
                    t = point + h
            elif op == 11:
                state = c_void_p()
                if lib("fmi2GetFMUstate", c, None if null else byref(state)) == 0 and state.value:
                    states.append(state)
            elif op == 12:
                lib("fmi2SetFMUstate", c, rng.choice(states) if states and not null else None)
            elif op == 13 and states:
                lib("fmi2FreeFMUstate", c, byref(states.pop(rng.randrange(len(states)))))
            elif op == 14 and states:
                state, size = rng.choice(states), c_size_t()
                if (
                    lib("fmi2SerializedFMUstateSize", c, state, byref(size)) != 0
                    or size.value > 10**7
                ):
                    continue
                buffer = create_string_buffer(size.value)
                if lib("fmi2SerializeFMUstate", c, state, buffer, size.value) != 0:
                    continue
                data = bytearray(buffer.raw)
                for _ in range(rng.choice([0, 1, 3, 20])):
                    if data:
                        data[rng.randrange(len(data))] = rng.randrange(256)
                if rng.random() < 0.2:
                    data = data[: rng.randrange(len(data) + 1)]
                # Into a new state, or over the one it came from.
                target = c_void_p(rng.choice([None, None, state.value]))
                status = lib(
                    "fmi2DeSerializeFMUstate",
                    c,
                    create_string_buffer(bytes(data), max(1, len(data))),
                    len(data),
                    byref(target),
                )
                if status == 0 and target.value and target.value != state.value:
                    states.append(target)
            elif op == 15:
                data = bytes(rng.randrange(256) for _ in range(rng.randint(0, 300)))
                target = c_void_p()
                if (
                    lib(
                        "fmi2DeSerializeFMUstate",
                        c,
                        create_string_buffer(data, max(1, len(data))),
                        len(data),
                        byref(target),
                    )
                    == 0
                    and target.value
                ):
                    states.append(target)
            elif op == 16:
                query = rng.choice(
                    [
                        "fmi2GetStatus",
                        "fmi2GetRealStatus",
                        "fmi2GetIntegerStatus",
                        "fmi2GetBooleanStatus",
                        "fmi2GetStringStatus",
                    ]
                )
                out = (
                    c_double()
                    if query == "fmi2GetRealStatus"
                    else c_int()
                    if query != "fmi2GetStringStatus"
                    else c_char_p()
                )
                lib(query, c, rng.randint(-1, 4), None if null else byref(out))
            elif op == 17:
                categories = [
                    rng.choice([b"logAll", b"logStatusError", b"nonsense", None])
                    for _ in range(rng.randint(0, 3))
                ]
                lib(
                    "fmi2SetDebugLogging",
                    c,
                    rng.choice([0, 1]),
                    len(categories),
                    array(c_char_p, categories) if categories else None,
                )
            elif op == 18:
                unknowns, knowns = references("Real"), references("Real")
                lib(
                    "fmi2GetDirectionalDerivative",
                    c,
                    array(c_uint, unknowns),
                    len(unknowns),
                    array(c_uint, knowns),
                    len(knowns),
                    array(c_double, [1.0] * len(knowns)),
                    array(c_double, [0.0] * len(unknowns)),
                )
            elif op in (19, 20):
                vrs = references("Real")
                name = "fmi2SetRealInputDerivatives" if op == 19 else "fmi2GetRealOutputDerivatives"
                lib(
                    name,
                    c,
                    array(c_uint, vrs),
                    len(vrs),
                    array(c_int, [1] * len(vrs)),
                    array(c_double, [0.0] * len(vrs)),
                )
        for state in states:
            lib("fmi2FreeFMUstate", c, byref(state))
        lib.free_instance(c)

    summary["statuses"] = lib.statuses
    summary["null_messages"] = null_messages
    return summary


if __name__ == "__main__":
    fmu_arg, seed_arg, count_arg = sys.argv[1:4]
    with tempfile.TemporaryDirectory(prefix="random-calls-") as tmp:
        print(json.dumps(main(Path(fmu_arg), Path(tmp), int(seed_arg), int(count_arg))))
