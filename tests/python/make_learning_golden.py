"""Writes ckcm/tests/data/learning_golden.txt: scipy's Butterworth designs and zero-phase
(Gustafsson) filterings that the Rust `ckcm::learning` module must reproduce.

    python tests/python/make_learning_golden.py            # (re)write the file
    python tests/python/make_learning_golden.py --check    # compare with the file

`test_robust_update.py` runs the check, so the file provably comes from the scipy pinned
in requirements.txt. The check demands every line to be the same text except the filtered
signals `y`, which may differ by 1e-10 of the case's largest |y|: scipy's Gustafsson
filtering solves small linear systems through LAPACK, whose kernels numpy picks per CPU,
and on an AMD EPYC (Zen 1) the last bits moved by up to 4e-12 against the file written on
another machine. The Rust test allows 1e-9. The input signal is built from exactly rounded
operations only (no libm), so Rust rebuilds it bit for bit instead of reading it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy
from scipy import signal

GOLDEN = Path(__file__).resolve().parents[2] / "ckcm" / "tests" / "data" / "learning_golden.txt"

#: (order, cutoff Hz, sample rate Hz, samples): the robust setting on a 1 s trial, then
#: low, high and odd orders, a cutoff near Nyquist and a short signal.
CASES = [
    (4, 8.0, 1000.0, 1000),
    (1, 20.0, 1000.0, 400),
    (2, 5.0, 1000.0, 400),
    (3, 150.0, 1000.0, 300),
    (6, 40.0, 1000.0, 500),
    (2, 450.0, 1000.0, 50),
]


def test_signal(n: int) -> list[float]:
    """A smooth arch plus a deterministic rough part: x_i = 0.3·s(1 − s) + 0.01·(r_i − 0.5)
    with s = i/n and r_i = (7919·i mod 1009)/1009."""
    out = []
    for i in range(n):
        s = i / n
        r = ((7919 * i) % 1009) / 1009
        out.append(0.3 * s * (1.0 - s) + 0.01 * (r - 0.5))
    return out


def render() -> str:
    lines = [
        "# Reference values for ckcm::learning, written by tests/python/make_learning_golden.py",
        f"# with scipy {scipy.__version__} and numpy {np.__version__}:",
        "# b, a = signal.butter(order, cutoff, fs=rate); y = signal.filtfilt(b, a, x, method='gust')",
        "# case <order> <cutoff Hz> <rate Hz> <samples>, then the lines b, a and y (repr floats).",
    ]
    for order, cutoff, rate, n in CASES:
        b, a = signal.butter(order, cutoff, fs=rate)
        y = signal.filtfilt(b, a, np.array(test_signal(n)), method="gust")
        lines.append(f"case {order} {cutoff!r} {rate!r} {n}")
        for name, values in (("b", b), ("a", a), ("y", y)):
            lines.append(name + " " + " ".join(repr(float(v)) for v in values))
    return "\n".join(lines) + "\n"


#: Largest difference of a filtered value from the file, relative to the case's largest |y|.
Y_TOLERANCE = 1e-10


def compare(written: str, fresh: str) -> str | None:
    """None when `written` matches `fresh` (text, but `y` within Y_TOLERANCE), else why not."""
    old, new = written.splitlines(), fresh.splitlines()
    if len(old) != len(new):
        return f"{len(old)} lines against {len(new)}"
    for number, (a, b) in enumerate(zip(old, new), start=1):
        if a == b:
            continue
        fa, fb = a.split(), b.split()
        if not (fa and fb and fa[0] == fb[0] == "y" and len(fa) == len(fb)):
            return f"line {number} differs"
        ya, yb = np.array(fa[1:], dtype=float), np.array(fb[1:], dtype=float)
        worst = float(np.max(np.abs(ya - yb)) / np.max(np.abs(yb)))
        if not worst <= Y_TOLERANCE:
            return f"line {number}: y differs by {worst:.3g} of its largest value"
    return None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare instead of writing")
    args = parser.parse_args()
    text = render()
    if args.check:
        problem = compare(GOLDEN.read_text(), text)
        print(f"{GOLDEN}: {'matches' if problem is None else 'DIFFERS, ' + problem}")
        return 0 if problem is None else 1
    GOLDEN.parent.mkdir(parents=True, exist_ok=True)
    tmp = GOLDEN.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(GOLDEN)
    print(f"wrote {GOLDEN}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
