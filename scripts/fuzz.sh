#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan) in build-fuzz, seeds their corpora from
# assets/ and runs each target for SECONDS (default 60), one after the other, on one core.
# Opt-in, not part of CI. Crashes land in build-fuzz/artifacts/<target>/; a crash or hang must
# become a regression test with its input (docs/reliability.md).
#   scripts/fuzz.sh [SECONDS] [TARGET...]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
seconds="${1:-60}"
shift || true
build="$root/build-fuzz"
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  targets=(tetgen_fuzz gmsh_fuzz vtk_legacy_fuzz scene_fuzz tool_script_fuzz pose_stream_fuzz)
fi

CC=clang CXX=clang++ cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPLIANT_FUZZ=ON \
  -DPLIANT_RENDER=OFF -DPLIANT_TESTS=OFF -DPLIANT_WERROR=ON > /dev/null
cmake --build "$build" --target "${targets[@]}" -j2
"$root/fuzz/make_corpus.sh" "$build/corpus"

status=0
for t in "${targets[@]}"; do
  mkdir -p "$build/artifacts/$t" "$build/corpus-out/$t"
  echo "== $t: ${seconds} s"
  # The first corpus folder receives new inputs; the seeds stay untouched. -timeout: a single
  # input taking longer than 10 s is a hang; -rss_limit_mb: more than 2 GB is an out-of-memory bug.
  if ! "$build/fuzz/$t" "$build/corpus-out/$t" "$build/corpus/$t" -max_total_time="$seconds" \
      -timeout=10 -rss_limit_mb=2048 -max_len=65536 -print_final_stats=1 \
      -artifact_prefix="$build/artifacts/$t/" 2>&1 | tail -n 25; then
    status=1
  fi
done
ls -l "$build"/artifacts/*/ 2>/dev/null | grep -v '^total' || true
exit $status
