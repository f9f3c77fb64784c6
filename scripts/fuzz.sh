#!/usr/bin/env bash
# Builds the libFuzzer harnesses of fuzz/ (the `fuzz` preset: clang, AddressSanitizer and
# UndefinedBehaviorSanitizer), runs each for SECONDS (default 25) from its seed corpus, then runs each
# over its regression inputs (fuzz/regressions/<harness>/: every crash found, kept forever).
#   bash scripts/fuzz.sh                       what CI runs (test.sh's fuzz stage)
#   SCALPEL_FUZZ_RSS_MB=4096 bash scripts/fuzz.sh 3600 gmsh vtu   an hour each for two harnesses
# A finding (a crash, a sanitizer report, an exception other than InputError, an input slower than
# 10 s, an allocation or a process above 2048 MB) fails the run; the input is left in build/fuzz/findings/<harness>/
# (docs/fuzzing.md). The corpus a run grows stays in build/fuzz/corpus/<harness>/ for the next run.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-25}
shift || true
all=(scenario pose_log gmsh tetgen vtu device_profile cut_table hid_report nrrd)
harnesses=("$@")
[ ${#harnesses[@]} -gt 0 ] || harnesses=("${all[@]}")
for h in "${harnesses[@]}"; do
  [ -d "fuzz/corpus/$h" ] || { echo "fuzz.sh: unknown harness '$h' (${all[*]})" >&2; exit 2; }
done

cmake --preset fuzz
cmake --build --preset fuzz

# Teem (the NRRD reader) leaks a little on some malformed headers; fuzz/lsan.supp names it.
export LSAN_OPTIONS="suppressions=$PWD/fuzz/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"

bin=build/fuzz/fuzz
logs=build/fuzz/logs
mkdir -p "$logs"
# -rss_limit_mb also bounds a single allocation (libFuzzer's malloc limit): a parser that would
# allocate gigabytes for a count a file declares is a finding, not a slow run. AddressSanitizer
# keeps the stack of every distinct allocation it meets, so a long run grows without leaking:
# SCALPEL_FUZZ_RSS_MB raises the process limit for it (docs/fuzzing.md).
limits=(-rss_limit_mb="${SCALPEL_FUZZ_RSS_MB:-2048}" -malloc_limit_mb=2048 -timeout=10)

run_one() {
  local h=$1
  mkdir -p "build/fuzz/corpus/$h" "build/fuzz/findings/$h"
  local dict=()
  [ -f "fuzz/dict/$h.dict" ] && dict=("-dict=fuzz/dict/$h.dict")
  "$bin/fuzz_$h" "${limits[@]}" "${dict[@]}" -max_total_time="$seconds" -print_final_stats=1 \
    -artifact_prefix="build/fuzz/findings/$h/" "build/fuzz/corpus/$h" "fuzz/corpus/$h" >"$logs/$h.log" 2>&1
}

# One harness per core at a time.
failed=()
pids=()
names=()
jobs=$(nproc)
for h in "${harnesses[@]}"; do
  run_one "$h" &
  pids+=($!)
  names+=("$h")
  if [ ${#pids[@]} -ge "$jobs" ]; then
    wait "${pids[0]}" || failed+=("${names[0]}")
    pids=("${pids[@]:1}")
    names=("${names[@]:1}")
  fi
done
for i in "${!pids[@]}"; do
  wait "${pids[$i]}" || failed+=("${names[$i]}")
done

for h in "${harnesses[@]}"; do
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$logs/$h.log")
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$logs/$h.log")
  rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$logs/$h.log")
  echo "fuzz.sh: $h: ${execs:-?} inputs in ${seconds} s (${rate:-?}/s), peak ${rss:-?} MB"
done

# Every input that once crashed a harness, run once each.
regressed=0
for h in "${harnesses[@]}"; do
  inputs=()
  if [ -d "fuzz/regressions/$h" ]; then
    while IFS= read -r -d '' f; do inputs+=("$f"); done < <(find "fuzz/regressions/$h" -type f -print0 | sort -z)
  fi
  [ ${#inputs[@]} -gt 0 ] || continue
  if "$bin/fuzz_$h" "${limits[@]}" "${inputs[@]}" >"$logs/$h.regressions.log" 2>&1; then
    echo "fuzz.sh: $h: ${#inputs[@]} regression inputs pass"
  else
    echo "fuzz.sh: $h: a regression input fails again (fuzz/regressions/$h/):" >&2
    tail -n 40 "$logs/$h.regressions.log" >&2
    regressed=1
  fi
done

for h in "${failed[@]}"; do
  echo "fuzz.sh: $h found a problem; the end of $logs/$h.log:" >&2
  tail -n 60 "$logs/$h.log" >&2
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz.sh: the inputs are in build/fuzz/findings/; once fixed, keep each in fuzz/regressions/<harness>/" >&2
fi
[ ${#failed[@]} -eq 0 ] && [ "$regressed" -eq 0 ]
