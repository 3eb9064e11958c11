#!/usr/bin/env bash
# CPU-time benchmarks, for a shared machine: a process's CPU time (user + sys) moves far less
# with other builds running than the wall time criterion reports, so base and after can be
# compared back to back even at load 3-4 on 2 cores. Every figure is the minimum over RUNS.
#
#   trial DIR [RUNS]          CPU ms per 15 s HLCS line trial of `orchestrator run` with the
#                             FMUs of DIR: (CPU(21 trials) - CPU(1 trial)) / 20, no recording
#   floor BIN [RUNS]          CPU ms per trial of the FMI-free floor (ckcm's `floor` example
#                             binary BIN): (CPU(30 trials) - CPU(0)) / 30, perf task-clock
#   master BIN DIR [RUNS]     CPU ms per recorded 15 s HLCS line trial of `Master` (the
#                             `master_trials` example binary BIN with the FMUs of DIR, the
#                             shipped scenario's recording): (CPU(21) - CPU(1)) / 20, perf
#                             task-clock. CKCM_UNRECORDED=1 records nothing
#   hlcs DIR FORMAT [RUNS]    wall and CPU s of `orchestrator run scenarios/line-hlcs.toml` as
#                             shipped (10 trials, 5 recorded) with the FMUs of DIR, recording
#                             in FORMAT (csv or parquet); every run is printed. It runs with
#                             the CLI's default --jobs (two lanes on two or more cores);
#                             CKCM_JOBS=N passes --jobs N
#   instructions DIR          instructions per 15 s HLCS line trial of `orchestrator run`
#                             with the FMUs of DIR under valgrind's cachegrind:
#                             (Ir(3 trials) - Ir(1 trial)) / 2, no recording. The same on
#                             every run, so it resolves changes of 1 % that the CPU time of a
#                             shared machine cannot; it does not see latency, so a change
#                             that only shortens a dependency chain needs the CPU figures
#
#   recording DIR FORMAT      instructions of recording one trial in FORMAT (csv or parquet)
#                             under cachegrind: Ir(one trial, recorded) - Ir(one trial, no
#                             [record]): the master's row copies, the formatting and the write
#   icache MASTER FLOOR DIR   simulated L1 instruction-cache misses per trial (cachegrind; a
#                             32 KiB, 8-way cache of 64-byte lines, CKCM_I1=size,ways,line for
#                             another) of an unrecorded `Master` trial (`master_trials` binary
#                             MASTER, the FMUs of DIR) and of the floor (`floor` binary FLOOR):
#                             (misses(3 trials) - misses(1)) / 2 each
#   footprint MASTER FLOOR DIR
#                             the code a 1 ms step runs, in 64-byte lines, for the same two
#                             binaries: every function that runs at least once per step (its
#                             instructions per trial, Ir(2 trials) - Ir(1), at least the
#                             trial's 15,000 steps) with the lines of it that one trial touches
#                             at all (cachegrind's misses in a 1 MiB cache, which holds
#                             everything). An upper bound: lines a function touches only at
#                             start-up count too, and same-named functions of the two FMU
#                             libraries count together. Code without symbols (`???:???`) is
#                             left out and its lines printed apart
#
# `trial`, `instructions` and `recording` run one lane (--jobs 1): they measure a trial's own
# cost.
#
# Needs: cargo xtask fmu; cargo build --release -p orchestrator (and for `floor`:
# cargo build --release -p ckcm --example floor; for `master`: cargo build --release
# -p orchestrator --example master_trials); GNU time and perf
# (apt-get install -y time linux-perf; valgrind for `instructions`, `recording`,
# `icache` and `footprint`). CKCM_ORCHESTRATOR
# picks another CLI binary.
# Usage: scripts/bench_cpu.sh trial|floor|master|hlcs|instructions|recording|icache|footprint ...
set -euo pipefail

mode=${1:?usage: scripts/bench_cpu.sh trial|floor|master|hlcs|instructions|recording|icache|footprint ...}
shift
repo=$(cd "$(dirname "$0")/.." && pwd)
bin=${CKCM_ORCHESTRATOR:-$repo/target/release/orchestrator}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# scenario DIR TRIALS RECORD: scenarios/line-hlcs.toml with the FMUs of DIR and TRIALS trials,
# without its [record] table unless RECORD is "record".
scenario() {
    local dir trials keep
    dir=$(cd "$1" && pwd)
    trials=$2
    keep=$3
    local out="$work/s$trials-$keep.toml"
    if [[ $keep == record ]]; then
        sed -e "s|../target/fmu|$dir|" -e "s/^trials = 10$/trials = $trials/" \
            "$repo/scenarios/line-hlcs.toml" >"$out"
    else
        sed -e "s|../target/fmu|$dir|" -e "s/^trials = 10$/trials = $trials/" \
            -e '/^\[record\]/,/^trials = \[/d' "$repo/scenarios/line-hlcs.toml" >"$out"
    fi
    echo "$out"
}

# cpu_of FILE: user + sys seconds written by GNU time -f "%U %S".
cpu_of() { awk '{print $1 + $2}' "$1"; }

# cachegrind LOG OPTIONS... -- COMMAND...: valgrind's cachegrind with the command's output
# discarded and valgrind's report in LOG. A command that fails or dies under valgrind (one of
# its instructions unknown to valgrind, say) stops the script with its report: the counts of
# a run cut short would be subtracted as if complete.
cachegrind() {
    local log=$1 status=0
    shift
    local opts=()
    while [[ $1 != -- ]]; do opts+=("$1"); shift; done
    shift
    valgrind --tool=cachegrind "${opts[@]}" "$@" >/dev/null 2>"$log" || status=$?
    if ((status != 0)); then
        echo "bench_cpu.sh: under valgrind, $* exited with status $status; valgrind's report" \
            "before its counts:" >&2
        sed -n '/ I *refs:/q;p' "$log" | tail -n 20 >&2
        exit 1
    fi
}

case $mode in
trial)
    dir=${1:?trial DIR [RUNS]}
    runs=${2:-3}
    one=$(scenario "$dir" 1 none)
    many=$(scenario "$dir" 21 none)
    best=
    for ((k = 0; k < runs; k++)); do
        /usr/bin/time -o "$work/t1" -f "%U %S" "$bin" run "$one" --out "$work/o1" --force --jobs 1 >/dev/null 2>&1
        /usr/bin/time -o "$work/t21" -f "%U %S" "$bin" run "$many" --out "$work/o21" --force --jobs 1 >/dev/null 2>&1
        ms=$(awk -v a="$(cpu_of "$work/t1")" -v b="$(cpu_of "$work/t21")" 'BEGIN {print (b - a) / 20 * 1000}')
        best=$(awk -v x="$ms" -v b="$best" 'BEGIN {print (b == "" || x < b) ? x : b}')
    done
    printf '%s: %.1f ms CPU per trial (min of %d)\n' "$dir" "$best" "$runs"
    ;;
floor)
    floor=${1:?floor BIN [RUNS]}
    runs=${2:-3}
    best=
    for ((k = 0; k < runs; k++)); do
        # The example runs one untimed learning trial before its repetitions: (CPU(30) - CPU(0)) / 30.
        t30=$(perf stat -x, -e task-clock "$floor" 30 2>&1 >/dev/null | awk -F, '/task-clock/ {print $1}')
        t0=$(perf stat -x, -e task-clock "$floor" 0 2>&1 >/dev/null | awk -F, '/task-clock/ {print $1}')
        ms=$(awk -v a="$t30" -v b="$t0" 'BEGIN {print (a - b) / 30}')
        best=$(awk -v x="$ms" -v b="$best" 'BEGIN {print (b == "" || x < b) ? x : b}')
    done
    printf '%s: %.2f ms CPU per trial (min of %d)\n' "$floor" "$best" "$runs"
    ;;
master)
    example=${1:?master BIN DIR [RUNS]}
    dir=${2:?master BIN DIR [RUNS]}
    runs=${3:-3}
    s=$(scenario "$dir" 10 record)
    flag=${CKCM_UNRECORDED:+--unrecorded}
    cpu_ms() { perf stat -x, -e task-clock "$example" "$s" "$1" $flag 2>&1 >/dev/null | awk -F, '/task-clock/ {print $1}'; }
    best=
    for ((k = 0; k < runs; k++)); do
        ms=$(awk -v a="$(cpu_ms 1)" -v b="$(cpu_ms 21)" 'BEGIN {print (b - a) / 20}')
        best=$(awk -v x="$ms" -v b="$best" 'BEGIN {print (b == "" || x < b) ? x : b}')
    done
    printf '%s: %.2f ms CPU per trial (min of %d)%s\n' "$dir" "$best" "$runs" "${flag:+, unrecorded}"
    ;;
hlcs)
    dir=${1:?hlcs DIR FORMAT [RUNS]}
    format=${2:?hlcs DIR FORMAT [RUNS]}
    runs=${3:-3}
    s=$(scenario "$dir" 10 record)
    for ((k = 0; k < runs; k++)); do
        /usr/bin/time -o "$work/th" -f "%e %U %S" "$bin" run "$s" --out "$work/oh" --force \
            --record-format "$format" ${CKCM_JOBS:+--jobs "$CKCM_JOBS"} >/dev/null 2>&1
        awk -v f="$format" '{printf "%s: wall %.2f s (%.0fx real time), CPU %.2f s\n", f, $1, 150 / $1, $2 + $3}' "$work/th"
    done
    ;;
instructions)
    dir=${1:?instructions DIR}
    for n in 1 3; do
        cachegrind "$work/vg$n" --cache-sim=no --cachegrind-out-file="$work/cg$n" -- \
            "$bin" run "$(scenario "$dir" $n none)" --out "$work/o$n" --force --jobs 1
    done
    ir() { grep -oP 'I\s+refs:\s+\K[0-9,]+' "$1" | tr -d ,; }
    printf '%s: %d instructions per trial\n' "$dir" $((($(ir "$work/vg3") - $(ir "$work/vg1")) / 2))
    ;;
recording)
    dir=${1:?recording DIR FORMAT}
    format=${2:?recording DIR FORMAT}
    for keep in none record; do
        s=$(scenario "$dir" 1 "$keep")
        # Of the shipped recorded trials only trial 0 exists in a one-trial campaign.
        sed -i 's/^trials = \[0, 1, 2, 3, 9\]$/trials = [0]/' "$s"
        cachegrind "$work/vg-$keep" --cache-sim=no --cachegrind-out-file="$work/cg-$keep" -- \
            "$bin" run "$s" --out "$work/o-$keep" --force --jobs 1 --record-format "$format"
    done
    ir() { grep -oP 'I\s+refs:\s+\K[0-9,]+' "$1" | tr -d ,; }
    printf '%s: %d instructions to record one trial in %s\n' "$dir" \
        $(($(ir "$work/vg-record") - $(ir "$work/vg-none"))) "$format"
    ;;
icache)
    example=${1:?icache MASTER FLOOR DIR}
    floor=${2:?icache MASTER FLOOR DIR}
    dir=${3:?icache MASTER FLOOR DIR}
    i1=${CKCM_I1:-32768,8,64}
    s=$(scenario "$dir" 10 record)
    # Each run's report gets its own file, and runs outside $(...): an `exit` in a command
    # substitution would end only the subshell.
    misses() { grep -oP 'I1\s+misses:\s+\K[0-9,]+' "$work/vg-$1" | tr -d ,; }
    for n in 1 3; do
        cachegrind "$work/vg-m$n" --cache-sim=yes --I1="$i1" --cachegrind-out-file=/dev/null -- \
            "$example" "$s" $n --unrecorded
        cachegrind "$work/vg-f$n" --cache-sim=yes --I1="$i1" --cachegrind-out-file=/dev/null -- \
            "$floor" $n
    done
    m=$((($(misses m3) - $(misses m1)) / 2))
    f=$((($(misses f3) - $(misses f1)) / 2))
    printf 'simulated L1i %s (size,ways,line): %d misses per unrecorded Master trial (%s), %d per floor trial\n' \
        "$i1" "$m" "$dir" "$f"
    ;;
footprint)
    example=${1:?footprint MASTER FLOOR DIR}
    floor=${2:?footprint MASTER FLOOR DIR}
    dir=${3:?footprint MASTER FLOOR DIR}
    s=$(scenario "$dir" 1 none)
    for n in 1 2; do
        cachegrind "$work/vg-m$n" --cache-sim=yes --I1=1048576,16,64 \
            --cachegrind-out-file="$work/cg-m$n" -- "$example" "$s" $n --unrecorded
        cachegrind "$work/vg-f$n" --cache-sim=yes --I1=1048576,16,64 \
            --cachegrind-out-file="$work/cg-f$n" -- "$floor" $n
    done
    # functions FILE: "lines<TAB>instructions<TAB>file:function" per row of cg_annotate's
    # function table (sed, not gawk's match(): Debian's awk is mawk). awk reads to the end:
    # an early exit would fail the pipeline on cg_annotate's broken pipe.
    functions() {
        cg_annotate --show=I1mr,Ir --sort=Ir --threshold=0 "$1" |
            awk '/file:function/ {on = 1; getline; next} on && /^-----/ {on = 0} on' |
            sed -E 's/^ *([0-9,]+) +\([^)]*\) +([0-9,]+) +\([^)]*\) +/\1\t\2\t/; s/,//g'
    }
    # Steps per trial from the scenario's stop time and step size (the floor example runs the
    # same 15 s at 1 ms).
    steps=$(awk '/^stop_time/ {d = $3} /^step_size/ {h = $3} END {printf "%.0f", d / h}' "$s")
    for who in m f; do
        functions "$work/cg-${who}1" >"$work/fn-${who}1"
        functions "$work/cg-${who}2" >"$work/fn-${who}2"
        label=$([[ $who == m ]] && echo "unrecorded Master trial ($dir)" || echo "floor trial")
        awk -F'\t' -v steps="$steps" -v label="$label" '
            NR == FNR {lines[$3] = $1; ir1[$3] = $2; next}
            $2 - ir1[$3] >= steps {
                per = ($2 - ir1[$3]) / steps
                if ($3 == "???:???") {unnamed = lines[$3]; next}
                total += lines[$3]; instr += per
                printf "  %5d lines %9.1f per step  %s\n", lines[$3], per, $3 | "sort -rn"
            }
            END {
                close("sort -rn")
                printf "%s: %d lines (%.1f KiB) of code run per step, %.0f instructions per step (%d lines without symbols left out)\n",
                    label, total, total * 64 / 1024, instr, unnamed
            }' "$work/fn-${who}1" "$work/fn-${who}2"
    done
    ;;
*)
    echo "unknown mode $mode: trial, floor, master, hlcs, instructions, recording, icache or footprint" >&2
    exit 2
    ;;
esac
