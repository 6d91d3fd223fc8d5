#!/usr/bin/env bash
# Sets up (installs missing packages), builds, and runs the default test suite with ctest.
# Long sweeps and soak runs carry the ctest label "long" and are excluded here; run them with
#   ctest --test-dir build -L long
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck disable=SC2086
bash scripts/setup.sh ${PLIANT_SETUP_FLAGS:-}
ctest --test-dir build --output-on-failure -j"$(nproc 2>/dev/null || echo 2)" -LE long --timeout 600
