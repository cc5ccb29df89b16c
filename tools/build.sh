#!/usr/bin/env bash
# Configures and builds Palpa in ./build (Release, Ninja, ccache).
# Usage: tools/build.sh [extra cmake --build args]
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
# Let ccache share results between clones in different folders.
export CCACHE_BASEDIR="$PWD"
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$jobs" "$@"
