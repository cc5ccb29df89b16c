#!/usr/bin/env bash
# Crash safety of the session recorder: kill -9 a recording process at
# random moments, RUNS times (100 by default), and check every file.
#   1. The recorder test (build/bin/test_record, Crash.*) with RUNS kills:
#      every file opens, says "interrupted", holds every tick the writer had
#      reported committed, its row counts never went down while it was being
#      written, every tick's inputs are what the script made, and its forces
#      replay bit for bit.
#   2. palpa-palpate --record killed RUNS times at random moments (0.2 to
#      3.2 s after its start): every
#      file opens in palpa-replay as "interrupted" and replays bit-identical
#      (or was killed before its file was made: the set-up is written to a
#      hidden sibling and linked to the name only when complete).
# Build first (tools/build.sh --target test_record palpa-palpate palpa-replay).
# Prints "crash-test: N/RUNS ... intact" lines; exits 1 on any failure.
set -euo pipefail
cd "$(dirname "$0")/.."
runs="${1:-100}"
bin=build/bin
for exe in test_record palpa-palpate palpa-replay; do
  [ -x "$bin/$exe" ] || { echo "crash-test: $bin/$exe not built" >&2; exit 2; }
done

echo "crash-test: recorder, $runs kills"
PALPA_CRASH_KILLS="$runs" "$bin/test_record" --gtest_filter='Crash.*' --gtest_brief=1 | grep -E "^crash:|FAILED|PASSED" || {
  echo "crash-test: the recorder test failed" >&2
  exit 1
}

dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
ok=0 unmade=0 finished=0 bad=0
for ((k = 1; k <= runs; k++)); do
  f="$dir/s$k.palpa"
  "$bin/palpa-palpate" --seconds 600 --probes 3 --record "$f" >/dev/null 2>&1 &
  pid=$!
  # 0.2 .. 3.2 s: while the organ loads, in the set-up, in the ticks.
  sleep "$(awk -v r=$RANDOM 'BEGIN { printf "%.3f", 0.2 + (r % 3000) / 1000 }')"
  kill -9 "$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
  if [ ! -e "$f" ]; then
    unmade=$((unmade + 1))
    continue
  fi
  out=$("$bin/palpa-replay" "$f" 2>&1) && rc=0 || rc=$?
  if grep -q ": interrupted, " <<<"$out" && grep -q "forces bit-identical" <<<"$out" && [ "$rc" -eq 0 ]; then
    ok=$((ok + 1))
  elif grep -q ": finished, " <<<"$out" && grep -q "forces bit-identical" <<<"$out" && [ "$rc" -eq 0 ]; then
    finished=$((finished + 1))  # it finished before the kill (a fast machine)
  elif grep -q "nothing to replay" <<<"$out" && [ "$rc" -eq 0 ]; then
    ok=$((ok + 1))
  else
    bad=$((bad + 1))
    echo "crash-test: run $k: rc $rc: $out" >&2
  fi
  rm -f "$f" "$f-wal" "$f-shm" "$dir"/.s$k.palpa.creating-*
done
echo "crash-test: palpa-palpate, $runs kills: $ok files interrupted and bit-identical on replay, $unmade killed before the session file was made, $finished finished before the kill, $bad bad"
[ "$bad" -eq 0 ]
