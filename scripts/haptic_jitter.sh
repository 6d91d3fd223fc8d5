#!/usr/bin/env bash
# The 1 kHz haptic jitter benchmark (issue 6): physics back to back on the probe scene (1,014-vertex
# tissue) and on probe_5k (4,851-vertex tissue), each for SECONDS wall-clock seconds, with the
# haptic thread beside it. Prints the table of `pliant bench --haptic`, the load average before
# and after (the machine is shared: read the numbers with the load) and, where rt-tests is
# installed, cyclictest's late wake-ups over as many seconds (the platform's share), and writes the JSON.
#
#   scripts/haptic_jitter.sh [BUILD_DIR] [SECONDS] [OUT_JSON] [extra pliant bench flags...]
#   e.g. scripts/haptic_jitter.sh build-interaction 10 /tmp/haptic_jitter.json --no-rt-priority
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-build}"
seconds="${2:-10}"
out="${3:-haptic_jitter.json}"
shift $(( $# < 3 ? $# : 3 ))
pliant="$here/$build/apps/pliant"
[[ "$build" = /* ]] && pliant="$build/apps/pliant"
if [[ ! -x "$pliant" ]]; then
  echo "haptic_jitter.sh: $pliant not built (cmake --build $build --target pliant)" >&2
  exit 2
fi
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg) ($(nproc) cores)"
# The platform's own wake-up lateness, if rt-tests is installed (apt-get install rt-tests): one
# SCHED_FIFO thread waking every 1 ms for SECONDS with nothing else of ours running. Wake-ups >= 1 ms
# late here are misses no haptic thread can avoid (docs/interaction.md "Session 20").
if command -v cyclictest >/dev/null 2>&1; then
  cyclictest -m -p 10 -i 1000 -D "$seconds" -q -t 1 -h 20000 2>/dev/null |
    awk '/^[0-9]/ { n += $2; if ($1 >= 1000) late += $2 } /Max Latencies/ { max = $4 }
         END { printf "platform (cyclictest, %d wake-ups): %d >= 1 ms late, max %.3f ms\n", n, late, max / 1000 }' ||
    echo "platform: cyclictest failed (needs root for SCHED_FIFO)"
else
  echo "platform: cyclictest not installed (apt-get install rt-tests): no baseline of the host's wake-up lateness"
fi
"$pliant" bench --haptic --seconds "$seconds" --json "$out" "$@" \
  "$here/assets/scenes/probe.json" "$here/assets/scenes/probe_5k.json"
echo "load after:  $(cut -d' ' -f1-3 /proc/loadavg)"
echo "wrote $out"
