#!/usr/bin/env bash
# Load test of the real-time loop (issue 9, item 5). Opt-in, not part of CI: it takes ~35 s and
# its numbers depend on the machine.
#
# Runs `pliant run SCENE --realtime` for IDLE + BUSY + IDLE seconds of wall time. During the
# middle phase BUSY_PROCS processes spin at full speed (default: one, i.e. the other core of a
# 2-core machine is saturated). From the run's ticks.csv (one row per tick: the clock time it was
# due, its step time, deadline miss, and the accuracy the governor had set) it prints, per phase:
# ticks run, deadline misses, skipped slots, step time p50/p99/max, and the lowest and final
# accuracy, so one sees the loop keep running, count its misses, engage the governor, and recover.
#
#   scripts/load_test.sh [SCENE] [OUT] [IDLE_S] [BUSY_S] [BUSY_PROCS]
#   (the scene's time step should equal its loop period, so --duration is wall time)
#   defaults: assets/scenes/load_test.json out-load 10 10 1
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
scene="${1:-$root/assets/scenes/load_test.json}"
out="${2:-out-load}"
idle="${3:-10}"
busy="${4:-10}"
procs="${5:-1}"
pliant="${PLIANT:-$root/build/apps/pliant}"
[ -x "$pliant" ] || { echo "load_test.sh: $pliant not built (bash scripts/setup.sh)" >&2; exit 2; }
total=$((idle + busy + idle))

echo "load: $(uptime)"
"$pliant" run "$scene" --realtime --duration "$total" --no-frames --quiet --out "$out" &
run_pid=$!
busy_pids=()
cleanup() { for p in "${busy_pids[@]}"; do kill "$p" 2>/dev/null || true; done; }
trap cleanup EXIT
sleep "$idle"
for ((i = 0; i < procs; ++i)); do
  ( while :; do :; done ) &
  busy_pids+=($!)
done
echo "busy: ${procs} spinning process(es) for ${busy} s"
sleep "$busy"
cleanup
busy_pids=()
echo "busy: stopped"
wait "$run_pid"

# The phases by the loop's own clock: ticks.csv's scheduled time starts at 0 when the loop starts,
# which is within a few ms of this script starting the run (scene loading comes first and is
# counted in the first idle phase).
awk -F, -v idle="$idle" -v busy="$busy" -v times="$out/phase_step_ms.txt" '
  NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
  {
    t = $col["scheduled_s"]; ph = (t < idle) ? 1 : (t < idle + busy) ? 2 : 3
    n[ph]++; print ph, $col["step_ms"] > times
    miss[ph] += $col["deadline_miss"]
    if (NR > 2) skip[ph] += $col["slot"] - last_slot - 1
    last_slot = $col["slot"]
    b = $col["binary_search_iterations"]; c = $col["solver_iterations"]
    if (!(ph in minb) || b < minb[ph]) minb[ph] = b
    if (!(ph in minc) || c < minc[ph]) minc[ph] = c
    lastb[ph] = b; lastc[ph] = c
  }
  END {
    for (ph = 1; ph <= 3; ++ph) if (ph in n) print ph, n[ph], miss[ph] + 0, skip[ph] + 0, minb[ph] "/" minc[ph], lastb[ph] "/" lastc[ph]
  }' "$out/ticks.csv" > "$out/phase_counts.txt"

printf '%-12s %7s %7s %8s %9s %9s %9s %14s %14s\n' phase ticks misses skipped "p50 ms" "p99 ms" "max ms" "min bs/cg" "end bs/cg"
names=("" "idle before" "busy" "idle after")
while read -r ph n misses skipped minacc endacc; do
  # nearest-rank percentiles of this phase's step times
  sorted=$(awk -v ph="$ph" '$1 == ph { print $2 }' "$out/phase_step_ms.txt" | sort -g)
  rank() { local k; k=$(awk -v n="$n" -v p="$1" 'BEGIN { k = int(p * n); if (k < p * n) k++; if (k < 1) k = 1; print k }'); sed -n "${k}p" <<< "$sorted"; }
  printf '%-12s %7d %7d %8d %9.3f %9.3f %9.3f %14s %14s\n' "${names[$ph]}" "$n" "$misses" "$skipped" \
    "$(rank 0.5)" "$(rank 0.99)" "$(tail -n 1 <<< "$sorted")" "$minacc" "$endacc"
done < "$out/phase_counts.txt"
