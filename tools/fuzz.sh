#!/usr/bin/env bash
# Builds one libFuzzer target (clang, ASan + UBSan, in build-fuzz/) and runs
# it on its seed corpus for a given time, one job, at low priority.
# Usage: tools/fuzz.sh TARGET SECONDS     TARGET: mesh, trajectory, igtl, scenario or session
#        tools/fuzz.sh all SECONDS         each target in turn, SECONDS each
# New inputs go to build-fuzz/corpus/TARGET (the seeds in fuzz/corpus/TARGET
# are read, never written); crashes to build-fuzz/artifacts/TARGET/. The last
# lines of libFuzzer's log (executions, cov:) are printed at the end and kept
# in build-fuzz/TARGET.log.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -ne 2 ]; then
  echo "usage: tools/fuzz.sh TARGET|all SECONDS (targets: mesh, trajectory, igtl, scenario, session)" >&2
  exit 2
fi
targets=("$1")
[ "$1" = all ] && targets=(mesh trajectory igtl scenario session)
seconds=$2
export CCACHE_BASEDIR="$PWD"
if [ ! -f build-fuzz/build.ninja ]; then
  CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPALPA_FUZZ=ON \
    -DPALPA_BUILD_TESTS=OFF -DPALPA_BUILD_BENCH=OFF -DPALPA_GUI=OFF >/dev/null
fi
for t in "${targets[@]}"; do
  if [ ! -d "fuzz/corpus/$t" ]; then echo "fuzz: no target '$t' (fuzz/corpus/$t is missing)" >&2; exit 2; fi
  # Two runs at once share build-fuzz/: one builds at a time.
  flock build-fuzz/.build-lock nice -n 10 cmake --build build-fuzz -j "$(nproc 2>/dev/null || echo 2)" --target "fuzz_$t"
  mkdir -p "build-fuzz/corpus/$t" "build-fuzz/artifacts/$t"
  # One job in one worker process; its log is fuzz-0.log in the target's own
  # working folder (so two targets can run at once, e.g. one per core).
  mkdir -p "build-fuzz/run-$t"
  (cd "build-fuzz/run-$t" && rm -f fuzz-0.log &&
   ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS=suppressions="$PWD/../../fuzz/lsan.supp" nice -n 15 "../bin/fuzz_$t" -jobs=1 -workers=1 -max_total_time="$seconds" \
     -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 -artifact_prefix="../artifacts/$t/" \
     "../corpus/$t" "../../fuzz/corpus/$t" >"../$t.main.log" 2>&1 || true
   if [ -f fuzz-0.log ]; then mv -f fuzz-0.log "../$t.log"; else cp "../$t.main.log" "../$t.log"; fi)
  echo "== fuzz_$t, $seconds s =="
  { grep -E "^#[0-9]+[[:space:]]+(INITED|DONE)" "build-fuzz/$t.log" || true; } | tail -2
  grep -E "^(stat::number_of_executed_units|stat::average_exec_per_sec|stat::peak_rss_mb|Done )" "build-fuzz/$t.log" || true
  if ls "build-fuzz/artifacts/$t/"* >/dev/null 2>&1; then
    echo "fuzz_$t: FINDINGS in build-fuzz/artifacts/$t/:"; ls "build-fuzz/artifacts/$t/"
  fi
done
