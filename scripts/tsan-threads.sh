#!/usr/bin/env bash
# ThreadSanitizer run of the threaded step (docs/threads.md "Session 10"): builds the determinism
# test (tests/interaction/threads_determinism_test.cpp: probe, three cubes and fruit dish with
# threads 1 / 2 / 3, bit-compared step by step) and what it links with -fsanitize=thread in
# build-tsan (RelWithDebInfo, render and benchmarks off), then runs ThreadsDeterminism.*. Any data
# race report makes the run exit 66. Debian's libtbb is not instrumented: oneTBB's own task objects are
# still reported (scripts/tsan-tbb.supp holds what can be suppressed safely; docs/threads.md).
#   scripts/tsan-threads.sh [BUILD_DIR]    (default build-tsan; JOBS=n sets the parallelism)
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build-tsan}"
jobs="${JOBS:-$(nproc 2>/dev/null || echo 2)}"
export TSAN_OPTIONS="${TSAN_OPTIONS:-halt_on_error=0:suppressions=$PWD/scripts/tsan-tbb.supp}"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPLIANT_RENDER=OFF -DPLIANT_BENCH=OFF -DPLIANT_TESTS=ON \
  -DCMAKE_CXX_FLAGS="${CXXFLAGS:-} -fsanitize=thread -fno-omit-frame-pointer" \
  -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=thread -DCMAKE_SHARED_LINKER_FLAGS=-fsanitize=thread
cmake --build "$build" -j"$jobs" --target test_interaction_threads_determinism_test
"$build/tests/test_interaction_threads_determinism_test" --gtest_filter='ThreadsDeterminism.*'
