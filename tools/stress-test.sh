#!/usr/bin/env bash
# Runs every loop and GUI test (CTest labels loop, loop_fuzz and app_*) a
# number of times in a row (20 by default) with two CPU-bound processes
# running beside them, and stops at the first run with a failure. Prints
# "stress: N/RUNS runs passed"; exits 0 only when every run passed.
#
# Usage: tools/stress-test.sh [RUNS] [extra ctest arguments]
#   BUILD_DIR  the build to test (default: build; build it first with tools/build.sh)
#   JOBS       parallel CTest jobs (default: nproc, as tools/test.sh runs them)
# Each run's log is kept in $BUILD_DIR/stress/run-N.log.
set -uo pipefail
cd "$(dirname "$0")/.."

runs=${1:-20}
[ $# -gt 0 ] && shift
build=${BUILD_DIR:-build}
jobs=${JOBS:-$(nproc 2>/dev/null || echo 2)}
labels='^(loop|loop_fuzz|app_.*)$'

if ! [[ "$runs" =~ ^[1-9][0-9]*$ ]]; then
  echo "stress: RUNS must be a positive number, got '$runs'" >&2
  exit 2
fi
count=$(ctest --test-dir "$build" -N -L "$labels" 2>/dev/null | sed -n 's/^Total Tests: //p')
if [ -z "$count" ] || [ "$count" -eq 0 ]; then
  echo "stress: no tests labelled $labels in $build (build first: bash tools/build.sh)" >&2
  exit 2
fi

# Two CPU hogs for the whole session, killed however the script ends.
hogs=()
stop_hogs() {
  for p in "${hogs[@]}"; do kill "$p" 2>/dev/null; done
  for p in "${hogs[@]}"; do wait "$p" 2>/dev/null; done
  hogs=()
}
trap stop_hogs EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
for _ in 1 2; do
  sh -c 'while :; do :; done' &
  hogs+=($!)
done

mkdir -p "$build/stress"
echo "stress: $count tests ($labels), $runs runs, ctest -j $jobs, 2 CPU hogs (pids ${hogs[*]})"
passed=0
for ((r = 1; r <= runs; r++)); do
  log="$build/stress/run-$r.log"
  start=$(date +%s)
  # A per-test timeout turns a hang into a failure.
  if ctest --test-dir "$build" -L "$labels" -j "$jobs" --timeout 600 --output-on-failure "$@" >"$log" 2>&1; then
    passed=$((passed + 1))
    echo "stress: run $r/$runs passed ($(($(date +%s) - start)) s)"
  else
    echo "stress: run $r/$runs FAILED ($(($(date +%s) - start)) s); log: $log"
    grep -E '^\s*[0-9]+ - |tests failed' "$log" || tail -n 40 "$log"
    break
  fi
done
echo "stress: $passed/$runs runs passed"
[ "$passed" -eq "$runs" ]
