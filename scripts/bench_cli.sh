#!/usr/bin/env bash
# Figures of the orchestrator CLI for BENCHMARKS.md, on generated scenarios:
#   growth [RUNS]  wall time against trial length and number of trials (hyperfine, RUNS runs)
#   rss            peak resident memory and wall time of `orchestrator paper` (GNU time)
#   profile        perf profile of a 6-trial 15 s HLCS line campaign, FMU symbols included
#
# Needs: cargo xtask fmu; cargo build --release -p orchestrator; and per mode hyperfine,
# GNU time or perf (apt-get install -y hyperfine time linux-perf).
# Usage: scripts/bench_cli.sh growth|rss|profile [RUNS]
set -euo pipefail

mode=${1:?usage: scripts/bench_cli.sh growth|rss|profile [RUNS]}
runs=${2:-3}
repo=$(cd "$(dirname "$0")/.." && pwd)
bin=${CKCM_ORCHESTRATOR:-$repo/target/release/orchestrator}
fmu_dir=$(cd "${CKCM_FMU_DIR:-$repo/target/fmu}" && pwd)
for f in "$bin" "$fmu_dir/CkcmPlant.fmu" "$fmu_dir/HlcsController.fmu"; do
    [[ -e $f ]] || { echo "$f missing: run cargo xtask fmu && cargo build --release -p orchestrator" >&2; exit 1; }
done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# scenario NAME TRAJECTORY DURATION TRIALS LEARNING: HLCS on TRAJECTORY for DURATION s, TRIALS
# trials, learning on or off, the example scenario's signals recorded at every sample for
# trial 0 only (every trial still writes its memory CSV and the summary, as any campaign does).
scenario() {
    cat >"$work/$1.toml" <<TOML
step_size = 0.001
stop_time = $3
trials = $4

[[fmu]]
name = "controller"
path = "$fmu_dir/HlcsController.fmu"
[fmu.parameters]
trajectory = "$2"
duration = $3
learning = $5
psi = 7.5

[[fmu]]
name = "plant"
path = "$fmu_dir/CkcmPlant.fmu"

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
variables = ["controller.error", "controller.force", "controller.memory_next", "plant.length", "plant.pose"]
interval = 1
trials = [0]

[metrics]
error = "controller.error"
rho = 1.0
pose = "plant.pose"
trajectory = { kind = "$2", duration = $3, home_height = 0.5 }
TOML
}

# One lane (--jobs 1): these figures are about the cost of a trial, not about using two cores.
run() { echo "$bin run $work/$1.toml --out $work/out-$1 --jobs 1"; }

growth() {
    echo "## Trial length (line, 1 trial)"
    for d in 5 15 60; do scenario "line-${d}s" line "$d.0" 1 true; done
    hyperfine --runs "$runs" --warmup 1 -N --export-markdown "$work/length.md" \
        -n "line 5 s" "$(run line-5s)" -n "line 15 s" "$(run line-15s)" -n "line 60 s" "$(run line-60s)" >/dev/null
    cat "$work/length.md"

    echo
    # Learning off: with it on, the unfiltered ILC diverges before trial 100 (docs/model.md §7) and the
    # run stops. Every trial still makes the same FMI calls and arithmetic.
    echo "## Number of trials (circle 5 s, PID only)"
    for k in 1 10 100; do scenario "circle-x$k" circle 5.0 "$k" false; done
    hyperfine --runs "$runs" --warmup 1 -N --export-markdown "$work/trials.md" \
        -n "circle x1" "$(run circle-x1)" -n "circle x10" "$(run circle-x10)" -n "circle x100" "$(run circle-x100)" >/dev/null
    cat "$work/trials.md"
}

rss() {
    /usr/bin/time -v "$bin" paper --fmu-dir "$fmu_dir" --out "$work/paper" 2>"$work/paper.time" >/dev/null
    grep -E "Maximum resident set size|Elapsed \\(wall clock\\)" "$work/paper.time"
}

# The FMUs run from a temporary directory the orchestrator deletes at exit, so perf cannot
# read their symbols afterwards: their libraries go into perf's build-id cache first, and
# the recording keeps the build ids (--buildid-mmap) to find them there.
profile() {
    for m in CkcmPlant HlcsController; do
        mkdir -p "$work/$m"
        (cd "$work/$m" && unzip -q "$fmu_dir/$m.fmu" "binaries/*")
        perf buildid-cache -f -a "$work/$m/binaries/linux64/$m.so"
    done
    scenario line-profile line 15.0 6 true
    perf record --buildid-mmap -F 4000 -g -o "$work/perf.data" $(run line-profile) 2>/dev/null >/dev/null
    echo "## By library"
    perf report -i "$work/perf.data" --no-children --sort dso -g none --stdio 2>/dev/null | grep '%' | head -8
    echo
    echo "## Top functions (self time)"
    perf report -i "$work/perf.data" --no-children --sort dso,sym -g none --stdio 2>/dev/null | grep '%' | head -30
}

case $mode in
    growth) growth ;;
    rss) rss ;;
    profile) profile ;;
    *) echo "unknown mode $mode (growth, rss or profile)" >&2; exit 2 ;;
esac
