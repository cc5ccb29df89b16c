#!/usr/bin/env bash
# ThreadSanitizer build (GCC, RelWithDebInfo, build-tsan/) of the threaded
# parts: the real-time loop, the device plugins and the workbench, then their
# tests (CTest labels loop*, plugins_*, devices, app_*). Any data race fails
# the test. Slow: not part of tools/test.sh or CI.
# Usage: tools/tsan.sh [extra ctest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
export CCACHE_BASEDIR="$PWD"
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="-fsanitize=thread" -DCMAKE_C_FLAGS="-fsanitize=thread" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=thread" \
  -DCMAKE_MODULE_LINKER_FLAGS="-fsanitize=thread" \
  -DPALPA_BUILD_BENCH=OFF -DPALPA_TEST_TIMEOUT=1200 >/dev/null
labels='^(loop.*|plugins_.*|devices|app_.*)$'
# Only the test executables of those labels (and what they need).
targets=$(cmake --build build-tsan --target help | sed -n 's/^\(test_\(loop\|plugins_\|devices\|app_\)[a-z_]*\):.*/\1/p' | sort -u)
plugins="palpa_device_mouse palpa_device_scripted palpa_device_spacemouse palpa_device_falcon palpa_device_igtl"
nice -n 10 cmake --build build-tsan -j "$jobs" --target $targets $plugins
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/tools/tsan.supp"
# The resident-memory tests measure TSan's shadow memory, not ours (they run
# in the normal suite): left out.
nice -n 10 ctest --test-dir build-tsan --output-on-failure -j "$jobs" -L "$labels" -E 'NoSurfaceConsumerKeepsMemoryFlat' "$@"
