#!/usr/bin/env bash
# Remakes fuzz/templates/sphere_6s.palpa, the valid session fuzz_session
# edits: 6 s of one scripted probe on a generated 100-vertex organ (a
# snapshot at 5 s), recorded by palpa-palpate, then trimmed to the ticks
# 0-511 and 4864-6000 around the snapshot (the reader takes chunks with a
# gap; fewer bytes make more executions per second). Remake it whenever the
# recorded layout changes (the session's `layout` meta), or the fuzzer stops
# at "recorded by a build of another layout" before the command and
# snapshot decoders.
# Usage: tools/make-fuzz-template.sh [build folder, default build]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
out=fuzz/templates/sphere_6s.palpa
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$build/bin/palpa-palpate" --organ-vertices 100 --probes 1 --seconds 6 --record "$tmp/s.palpa" >/dev/null
sqlite3 "$tmp/s.palpa" <<'SQL'
PRAGMA journal_mode=DELETE;
DELETE FROM tick_chunks WHERE first_tick >= 512 AND first_tick < 4864;
DELETE FROM probe_chunks WHERE first_tick >= 512 AND first_tick < 4864;
VACUUM;
SQL
mv "$tmp/s.palpa" "$out"
echo "$out: $(stat -c %s "$out") bytes, layout $(sqlite3 "$out" "select value from meta where key='layout'" | cut -c1-60)..."
