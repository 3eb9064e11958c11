#!/usr/bin/env python3
"""Where the CPU time of a profiled `orchestrator paper` run goes, in the categories of
BENCHMARKS.md: co-simulation, the learning update between trials, figures and report
(with reading recorded trials back), recording, start-up, result files, kernel, libc, and
the rest.

    perf record -F 1000 -o paper.data target/release/orchestrator paper --jobs 1 --out DIR
    scripts/paper_split.py paper.data

Each sample counts where it fell (the leaf function): the FMU libraries and libm (whose
`expm1` only the plant's friction calls in a trial) are co-simulation; the orchestrator's
own functions go by module and crate name; libc's (`memmove`, `malloc`, …) and the
kernel's (file writes, page faults) serve every category and are listed on their own.
The patterns are module and crate names; a new module may need a line below. `--show`
lists every function counted outside co-simulation, to check them.
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections import Counter

#: (category, pattern over "dso symbol"), tried in order.
CATEGORIES: list[tuple[str, re.Pattern[str]]] = [
    (
        "co-simulation",
        re.compile(
            r"CkcmPlant|HlcsController|libm\.so|orchestrator::master::"
            r"|fmi2_import::instance|fmi2::import::instance"
            r"|ckcm::(?!learning|metrics)"
        ),
    ),
    # The memory update between trials (the robust update's zero-phase filter).
    ("learning update", re.compile(r"ckcm::learning")),
    # Reading recorded trials back is part of making the figures.
    (
        "figures and report",
        re.compile(
            r"plotters|rustfft|paper::|output::(plots|convergence_plot|sweep_plots)|ttf|font"
            r"|png|image::|ckcm::metrics|read_recording_csv|csv_core::reader|csv::byte_record"
            r"|dec2flt|f64 as core::str::traits::FromStr"
        ),
    ),
    (
        "recording",
        re.compile(
            r"output::(csv|parquet|recording)|campaign::writers|zmij|parquet::|arrow"
            r"|flt2dec|float_to_decimal|float_to_exponential|write_formatted_parts"
            r"|csv_core::writer|bufwriter"
        ),
    ),
    (
        "start-up",
        re.compile(
            r"(?<!::)zip::|zlib|inflate|quick_xml|fmi2_md"
            r"|fmi2_import::(fmu|extract|functions|binary)|ld-linux|scenario::|toml|crc32fast"
        ),
    ),
    ("result files", re.compile(r"output::atomic|campaign::")),
    ("kernel", re.compile(r"\[kernel")),
    ("libc", re.compile(r"libc\.so")),
]


#: `perf record -F` of the usage above: samples per CPU second.
RATE = 1000


def main() -> None:
    show = "--show" in sys.argv
    if show:
        sys.argv.remove("--show")
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    report = subprocess.run(
        [
            "perf", "report", "-i", sys.argv[1], "--no-children", "--sort", "dso,sym",
            "--stdio", "-q", "-g", "none", "-F", "sample,dso,sym", "--percent-limit", "0",
        ],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    counts: Counter[str] = Counter()
    rest: Counter[str] = Counter()
    for line in report.splitlines():
        parts = line.split(None, 1)
        if len(parts) != 2 or not parts[0].isdigit():
            continue
        n, frame = int(parts[0]), parts[1]
        found = next((c for c, p in CATEGORIES if p.search(frame)), None)
        if show and found not in (None, "co-simulation"):
            print(f"{n:8} {found:20} {' '.join(frame.split())[:110]}")
        if found is None:
            rest[frame] += n
            found = "the rest"
        counts[found] += n
    total = sum(counts.values())
    print(f"{total} samples")
    for name in [c for c, _ in CATEGORIES] + ["the rest"]:
        n = counts[name]
        print(f"{name:20} {n:8} {100 * n / max(total, 1):5.1f} %  {n / RATE:6.2f} s")
    print("largest in the rest:")
    for frame, n in rest.most_common(8):
        print(f"  {n:8}  {' '.join(frame.split())}")


if __name__ == "__main__":
    main()
