#!/usr/bin/env bash
# Fingerprint of what a build computes, for checking that a change meant to be exact is bit-exact
# (a developer's tool, not part of the test suite: results agree only on one machine and compiler).
#   scripts/fingerprint.sh BUILD_DIR OUT_DIR     run the workloads with BUILD_DIR's binaries
#   scripts/fingerprint.sh --compare DIR_A DIR_B compare two such runs; exit 1 on any difference
# Workloads: the default scene assets/scenes/probe.json with 1 and 2 threads (all 2,800 steps), three
# paper scenes (three cubes 1,500 steps, membrane stack 400, fruit dish 300) and, when BUILD_DIR has
# the benchmarks (-DPLIANT_BENCH=ON), bench/beam_hash's three bit-for-bit beam hashes. Compared:
# tool_forces.csv byte for byte, steps.csv without its timing columns (step_ms .. report_ms), the
# beam hashes line for line.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)

if [ "${1:-}" = "--compare" ]; then
  [ $# -eq 3 ] || { echo "usage: $0 --compare DIR_A DIR_B" >&2; exit 2; }
  a=$2 b=$3 status=0
  for run in probe probe_threads2 three_cubes membrane_stack fruit_dish; do
    if [ ! -d "$a/$run" ] || [ ! -d "$b/$run" ]; then echo "$run: missing in one of the two"; status=1; continue; fi
    if cmp -s "$a/$run/tool_forces.csv" "$b/$run/tool_forces.csv"; then forces=identical; else forces=DIFFERENT; status=1; fi
    if cmp -s <(cut -d, -f1-17,24 "$a/$run/steps.csv") <(cut -d, -f1-17,24 "$b/$run/steps.csv"); then
      steps=identical
    else
      # (cmp exits 1 on a difference: under pipefail the substitution would end the script silently)
      steps="DIFFERENT from row $( (cmp <(cut -d, -f1-17,24 "$a/$run/steps.csv") <(cut -d, -f1-17,24 "$b/$run/steps.csv") || true) | awk '{print $NF}')"
      status=1
    fi
    echo "$run: tool_forces.csv $forces, steps.csv (non-timing columns) $steps"
  done
  if [ -f "$a/beam_hash.txt" ] && [ -f "$b/beam_hash.txt" ]; then
    if cmp -s "$a/beam_hash.txt" "$b/beam_hash.txt"; then echo "beam hashes: identical"; else echo "beam hashes: DIFFERENT"; diff "$a/beam_hash.txt" "$b/beam_hash.txt" || true; status=1; fi
  else
    echo "beam hashes: not in both"
  fi
  exit $status
fi

[ $# -eq 2 ] || { echo "usage: $0 BUILD_DIR OUT_DIR | --compare DIR_A DIR_B" >&2; exit 2; }
build=$(cd "$1" && pwd)
mkdir -p "$2"
out=$(cd "$2" && pwd)
pliant="$build/apps/pliant"
[ -x "$pliant" ] || { echo "$0: no $pliant" >&2; exit 2; }
cd "$root"
run() {  # name, scene, extra flags...
  local name=$1 scene=$2
  shift 2
  rm -rf "${out:?}/$name"
  "$pliant" run "$scene" --out "$out/$name" --no-frames --quiet "$@" > "$out/$name.log" 2>&1
}
run probe assets/scenes/probe.json --threads 1
run probe_threads2 assets/scenes/probe.json --threads 2
run three_cubes assets/scenes/paper/three_cubes.json --steps 1500
run membrane_stack assets/scenes/paper/membrane_stack.json --steps 400
run fruit_dish assets/scenes/paper/fruit_dish.json --steps 300
if [ -x "$build/bench/beam_hash" ]; then "$build/bench/beam_hash" > "$out/beam_hash.txt"; fi
echo "fingerprint: wrote $out"
