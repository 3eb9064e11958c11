#!/usr/bin/env bash
# Mutation testing of the FMU crates (fmu-plant, fmu-controller) through the packaged FMUs, as
# docs/testing.md describes. cargo-mutants cannot do it alone: the FMU-level tests load .fmu
# archives, so every mutant must be built and packaged before the tests run.
#
# For each mutant of `cargo mutants --list --json --diff`: apply its diff in place, build the
# mutated crate in the incremental `mutants` profile, package both FMUs (linux64 binaries
# only) into OUT/fmu, run the FMU-level orchestrator tests against them (CKCM_FMU_DIR), then
# the crate's own tests if those passed, and restore the file. Results: OUT/results.tsv
# (index, outcome, seconds, mutant). Outcomes: unviable (does not build), caught (FMU-level
# tests), caught_in_crate (the crate's tests), missed.
#
# Needs: cargo-mutants, a clean tree (it edits sources in place and restores them with
# `git checkout`; do not edit while it runs). CKCM_MUTANTS_FROM=I starts at mutant I (0-based,
# in the list's order), to carry on a run that was stopped; results.tsv is then appended to.
# Usage: scripts/mutants_fmu.sh OUT
set -uo pipefail

from=${CKCM_MUTANTS_FROM:-0}
if ! [[ $from =~ ^(0|[1-9][0-9]*)$ ]]; then
  echo "CKCM_MUTANTS_FROM=$from: expected a mutant index (0, 1, ...)" >&2
  exit 2
fi
out=$(mkdir -p "${1:?usage: scripts/mutants_fmu.sh OUT}" && cd "$1" && pwd)
repo=$(cd "$(dirname "$0")/.." && pwd)
cd "$repo"
if [ -n "$(git status --porcelain)" ]; then
  echo "the tree has uncommitted changes; commit or stash them first" >&2
  exit 2
fi
mkdir -p "$out/fmu"
export CKCM_FMU_DIR="$out/fmu"
tests=(--test control_law --test reference_figures --test parameters_reach_model
  --test fmu_hardening --test fmu_abi --test noise_e2e --test master_api --test fuzz_fmu_state
  --test fmu_illegal_calls --test cli_run_discard)
package() { python3 "$repo/scripts/package_fmu_linux.py" "$repo" "$out/fmu"; }

cargo mutants --list --json --diff -p fmu-plant -p fmu-controller > "$out/mutants.json"
n=$(python3 -c "import json,sys; print(len(json.load(open(sys.argv[1]))))" "$out/mutants.json")
if ((from >= n)); then
  echo "CKCM_MUTANTS_FROM=$from: there are only $n mutants (0 to $((n - 1)))" >&2
  exit 2
fi
echo "mutants: $n"
cargo build --profile mutants -q -p fmu-plant -p fmu-controller && package || exit 1
cargo build -q -p foreign-fmu || exit 1
cargo test -q -p orchestrator "${tests[@]}" > "$out/baseline.log" 2>&1 \
  || { echo "the unmutated tree fails the selection: see $out/baseline.log" >&2; exit 1; }
((from == 0)) && : > "$out/results.tsv"
for ((i = from; i < n; i++)); do
  python3 - "$out/mutants.json" "$i" "$out/cur.diff" > "$out/cur.meta" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))[int(sys.argv[2])]
open(sys.argv[3], "w").write(m["diff"])
print(m["file"], m["package"], m["name"].replace("\t", " "), sep="\t")
PY
  IFS=$'\t' read -r file pkg name < "$out/cur.meta"
  if ! patch -s "$file" < "$out/cur.diff"; then
    git checkout -q -- "$file"
    printf '%s\tpatch-failed\t0s\t%s\n' "$i" "$name" | tee -a "$out/results.tsv"
    continue
  fi
  t0=$(date +%s)
  if ! cargo build --profile mutants -q -p "$pkg" > "$out/build.log" 2>&1; then
    r=unviable
  elif ! package; then
    r=package-failed
  elif ! timeout 300 cargo test -q -p orchestrator "${tests[@]}" > "$out/test_$i.log" 2>&1; then
    r=caught
  elif ! timeout 300 cargo test --profile mutants -q -p "$pkg" > "$out/unit_$i.log" 2>&1; then
    r=caught_in_crate
  else
    r=missed
  fi
  git checkout -q -- "$file"
  [ "$r" = caught ] && rm -f "$out/test_$i.log"
  printf '%s\t%s\t%ss\t%s\n' "$i" "$r" "$(($(date +%s) - t0))" "$name" | tee -a "$out/results.tsv"
done
# Leave OUT/fmu packaged from the unmutated sources.
cargo build --profile mutants -q -p fmu-plant -p fmu-controller && package
