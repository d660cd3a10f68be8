#!/usr/bin/env bash
# Fuzz every parser a user feeds (issue 16): builds fuzz/ with clang
# (libFuzzer, AddressSanitizer, UndefinedBehaviorSanitizer) in build-fuzz/
# and runs each target for SECONDS (default 600), JOBS targets at a time
# (default 2). The grown corpus stays in build-fuzz/corpus/<target> (seeded
# from fuzz/corpus/<target>, which is kept small); a crash, hang or
# sanitizer report is written to build-fuzz/artifacts/<target>/ and makes
# this script exit 1. Results: docs/reliability.md.
#
#   bash bench/fuzz.sh [SECONDS] [JOBS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
jobs=${2:-2}
command -v clang++ >/dev/null || apt-get install -y clang libclang-rt-dev
cmake -S fuzz -B build-fuzz -DCMAKE_CXX_COMPILER=clang++ >/dev/null
cmake --build build-fuzz -j2 >/dev/null
targets=(case_file measured_run maps drive)
run() {
  local t=$1
  mkdir -p build-fuzz/corpus/$t build-fuzz/artifacts/$t
  cp -n fuzz/corpus/$t/* build-fuzz/corpus/$t/ 2>/dev/null || true
  build-fuzz/bin/fuzz_$t build-fuzz/corpus/$t -max_total_time=$seconds -timeout=10 -rss_limit_mb=2048 \
    -max_len=20000 -print_final_stats=1 -artifact_prefix=build-fuzz/artifacts/$t/ \
    > build-fuzz/fuzz_$t.log 2>&1
  local rc=$?
  local execs
  execs=$(grep -m1 "stat::number_of_executed_units" build-fuzz/fuzz_$t.log | awk '{print $2}')
  echo "$t: exit $rc, ${execs:-?} inputs in ${seconds} s, corpus $(ls build-fuzz/corpus/$t | wc -l) files," \
       "findings $(ls build-fuzz/artifacts/$t | wc -l)"
  return $rc
}
export -f run
export seconds
status=0
printf '%s\n' "${targets[@]}" | xargs -P "$jobs" -I{} bash -c 'run {}' || status=1
exit $status
