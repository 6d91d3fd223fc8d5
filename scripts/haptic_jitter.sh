#!/usr/bin/env bash
# The 1 kHz haptic jitter benchmark (issue 6): physics back to back on the probe scene (1,014-vertex
# tissue) and on probe_5k (4,851-vertex tissue), each for SECONDS wall-clock seconds, with the
# haptic thread beside it. Prints the table of `pliant bench --haptic` and the load average before
# and after (the machine is shared: read the numbers with the load), and writes the JSON.
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
"$pliant" bench --haptic --seconds "$seconds" --json "$out" "$@" \
  "$here/assets/scenes/probe.json" "$here/assets/scenes/probe_5k.json"
echo "load after:  $(cut -d' ' -f1-3 /proc/loadavg)"
echo "wrote $out"
