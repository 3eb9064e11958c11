#!/usr/bin/env bash
# Sweep throughput: cases per core-hour for a 20-trial circle case without recording, and the
# speed-up of --jobs 2 over --jobs 1 (both from one run of this script, so the ratio holds on a
# shared machine). Needs the FMUs and the release orchestrator:
#   cargo xtask fmu && cargo build --release -p orchestrator && scripts/bench_sweep.sh
set -euo pipefail
cd "$(dirname "$0")/.."
orch=target/release/orchestrator
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cases=${CASES:-8}
cat > "$work/sweep.toml" <<TOML
base = "$PWD/scenarios/circle-robust.toml"
trials = 20
[[axis]]
name = "mass_scale"
parameters = ["plant.platform_mass"]
scale = true
linspace = [0.8, 1.2, $cases]
TOML
run() { # jobs → seconds of wall time
  local out="$work/out-$1-$RANDOM"
  local t0 t1
  t0=$(date +%s.%N)
  "$orch" sweep "$work/sweep.toml" --out "$out" --jobs "$1" 2>/dev/null
  t1=$(date +%s.%N)
  echo "$t1 - $t0" | bc -l
}
for round in 1 2; do
  w1=$(run 1)
  w2=$(run 2)
  printf 'round %d: %d cases, --jobs 1 %.2f s (%.0f cases per core-hour), --jobs 2 %.2f s, speed-up %.2fx\n' \
    "$round" "$cases" "$w1" "$(echo "3600 * $cases / $w1" | bc -l)" "$w2" "$(echo "$w1 / $w2" | bc -l)"
done
