#!/usr/bin/env bash
# Runs every reader harness of a HOCURVE_FUZZ build for a bounded time under ASan/UBSan and reports,
# per reader, CPU seconds, executions and libFuzzer's coverage (cov: edges, ft: features).
# Usage: tests/fuzz/run.sh BUILD_DIR [SECONDS_EACH=60] [HARNESS...]
#        (FUZZ_FLAGS="-use_value_profile=1" adds libFuzzer flags)
# Seeds are made at run time (make_seeds.py, from ../shared/meshes) plus tests/fuzz/regressions/;
# the corpus grows in BUILD_DIR/fuzz-corpus/<reader> across runs; a failing input is saved as
# BUILD_DIR/fuzz-artifacts/<reader>-crash-* (or leak-, timeout-, oom-) and the script exits 1.
set -uo pipefail
cd "$(dirname "$0")/../.."
build=$(realpath "$1")
secs=${2:-60}
shift $(( $# >= 2 ? 2 : $# ))
harnesses=("$@")
[ ${#harnesses[@]} -gt 0 ] || harnesses=(stl obj ply off msh gzip)

/usr/bin/python3 tests/fuzz/make_seeds.py "$build/fuzz-seeds" || exit 1
mkdir -p "$build/fuzz-artifacts"
failed=0
printf '%-5s %8s %10s %7s %7s  %s\n' reader cpu_s execs cov ft result > "$build/fuzz-summary.txt"
for h in "${harnesses[@]}"; do
  mkdir -p "$build/fuzz-corpus/$h"
  log="$build/fuzz-$h.log"
  dict=()
  [ -f "tests/fuzz/$h.dict" ] && dict=(-dict="tests/fuzz/$h.dict")
  # -timeout: a unit slower than 10 s is a hang; -rss_limit_mb also caps single allocations (lying
  # counts); -max_len: the seeds are at most 16 KiB; -dict: the reader's keywords (tests/fuzz/<h>.dict).
  /usr/bin/time -f '%U %S' -o "$build/fuzz-$h.time" \
    "$build/fuzz_$h" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -max_len=16384 \
    -print_final_stats=1 -artifact_prefix="$build/fuzz-artifacts/$h-" "${dict[@]}" ${FUZZ_FLAGS:-} \
    "$build/fuzz-corpus/$h" "$build/fuzz-seeds/$h" tests/fuzz/regressions > "$log" 2>&1
  rc=$?
  cpu=$(awk 'END { printf "%.0f", $1 + $2 }' "$build/fuzz-$h.time" 2>/dev/null || echo "?")
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
  result=ok
  if [ $rc -ne 0 ]; then
    result="FAILED (exit $rc, see $log)"
    failed=1
  fi
  printf '%-5s %8s %10s %7s %7s  %s\n' "$h" "$cpu" "${execs:-?}" "${cov:-?}" "${ft:-?}" "$result" | tee -a "$build/fuzz-summary.txt"
done
[ $failed -eq 0 ] || grep -h -A12 '^==[0-9]*==ERROR\|^SUMMARY\|runtime error\|deadly signal\|ERROR: libFuzzer' "$build"/fuzz-*.log | head -60
exit $failed
