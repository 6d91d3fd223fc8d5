#!/usr/bin/env bash
# Installs the Debian packages Pliant needs (only those missing), then configures and builds.
# Non-interactive and idempotent; run as root on Debian 12. Usage:
#   scripts/setup.sh [--build-dir DIR] [--no-render] [--bench] [--sanitize] [--werror] [--no-build]
set -euo pipefail

build_dir=build
cmake_args=()
do_build=1
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) build_dir="$2"; shift 2 ;;
    --no-render) cmake_args+=(-DPLIANT_RENDER=OFF); shift ;;
    --bench) cmake_args+=(-DPLIANT_BENCH=ON); shift ;;
    --sanitize) cmake_args+=(-DPLIANT_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo); shift ;;
    --werror) cmake_args+=(-DPLIANT_WERROR=ON); shift ;;
    --no-build) do_build=0; shift ;;
    *) echo "setup.sh: unknown option '$1'" >&2; exit 2 ;;
  esac
done

root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"

packages=(
  build-essential cmake pkg-config
  libeigen3-dev nlohmann-json3-dev libcli11-dev libtbb-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libosmesa6-dev libglm-dev libpng-dev
  gnuplot-nox
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

[ "$do_build" = 1 ] || exit 0
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B "$build_dir" "${cmake_args[@]}" >/dev/null
cmake --build "$build_dir" -j"$jobs"
