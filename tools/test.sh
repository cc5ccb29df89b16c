#!/usr/bin/env bash
# Install what is missing, build everything, and run every test.
# Tests that need a display start their own Xvfb; tests that cannot run say why.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
bash tools/build.sh
jobs=$(nproc 2>/dev/null || echo 2)
ctest --test-dir build --output-on-failure -j "$jobs" "$@"
