#!/usr/bin/env bash
# Fuzzes every reader of the tools (16-bit PNG depth, pose files, intrinsics/number strings, PLY/PCD
# clouds when present) with libFuzzer + ASan + UBSan, each for N seconds with a fixed seed.
# Usage: bash scripts/fuzz.sh [seconds-per-target] [build-dir]
#   CI:        bash scripts/fuzz.sh 15
#   long run:  bash scripts/fuzz.sh 3600          (an hour per target; keeps the corpus in
#              <build-dir>/corpus/<target> so a later long run continues from it: FUZZ_KEEP_CORPUS=1)
# A crash leaves the input in <build-dir>/artifacts/<target>/; turn it into a regression test by
# copying it to tests/reliability/regressions/<target>/ (test_reliability replays every file there).
# Prints one JSON line per target: {"target","seconds","seed","runs","execs_per_s","corpus","crashes"}.
set -euo pipefail
cd "$(dirname "$0")/.."
secs="${1:-30}"
build="${2:-build-fuzz}"
seed="${FUZZ_SEED:-12345}"
bash scripts/setup.sh
CXX=clang++ CC=clang cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DBINPICK_BUILD_FUZZERS=ON \
  -DBUILD_TESTING=OFF -DBINPICK_BUILD_TOOLS=OFF -DBINPICK_BUILD_BENCHMARKS=OFF -DBINPICK_BUILD_EXAMPLES=OFF \
  -DBINPICK_USE_OPENMP=OFF >/dev/null
cmake --build "$build" --target binpick_fuzzers -j2 >/dev/null
seeds="$build/seeds"
rm -rf "$seeds"
"$build/fuzz/binpick_fuzz_seeds" "$seeds"
status=0
while read -r target; do
  [ -n "$target" ] || continue
  corpus="$build/corpus/$target"
  artifacts="$build/artifacts/$target"
  # A fresh corpus per run keeps a CI run reproducible for a given seed and time.
  [ "${FUZZ_KEEP_CORPUS:-0}" = 1 ] || rm -rf "$corpus"
  rm -rf "$artifacts"
  mkdir -p "$corpus" "$artifacts"
  log="$build/$target.log"
  set +e
  ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    "$build/fuzz/$target" -seed="$seed" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=512 \
    -max_len=65536 -print_final_stats=1 -artifact_prefix="$artifacts/" "$corpus" "$seeds/$target" >"$log" 2>&1
  rc=$?
  set -e
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  eps=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo 0)
  ncorpus=$(ls "$corpus" | wc -l)
  crashes=$(ls "$artifacts" | wc -l)
  echo "{\"target\":\"$target\",\"seconds\":$secs,\"seed\":$seed,\"runs\":${runs:-0},\"execs_per_s\":${eps:-0},\"corpus\":$ncorpus,\"crashes\":$crashes}"
  if [ $rc -ne 0 ] || [ "$crashes" -ne 0 ]; then
    echo "fuzz.sh: $target failed (exit $rc); log: $log" >&2
    tail -n 40 "$log" >&2
    status=1
  fi
done <"$build/fuzzers.txt"
exit $status
