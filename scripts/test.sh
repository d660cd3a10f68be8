#!/usr/bin/env bash
# Sets up (scripts/setup.sh) and runs the default test suite. Slow cases carry
# the ctest label "slow" and run only with: scripts/test.sh --all
#   scripts/test.sh --sanitize   the fast tests on a build with AddressSanitizer
#                                and UndefinedBehaviorSanitizer (build-sanitize/;
#                                docs/reliability.md)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
case "${1:-}" in
  --all)
    cd build && ctest -j"$(nproc)" --output-on-failure ;;
  --sanitize)
    flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
    cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
      -DRECTIFY_TEST_TIMEOUT_FACTOR=5
    cmake --build build-sanitize -j"$(nproc)"
    # Leaks are not checked: MPI and PETSc keep their allocations until exit.
    # Any other report stops the test that made it.
    # verify_asan_link_order=0: the fault tests preload a library of their own
    # (tests/fault_injection) ahead of the sanitizer's runtime.
    export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:strict_string_checks=1:verify_asan_link_order=0
    export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
    # Extra arguments go to ctest, e.g. -R 'Faults|Design' for a part.
    cd build-sanitize && ctest -j"$(nproc)" --output-on-failure -LE slow "${@:2}" ;;
  "")
    cd build && ctest -j"$(nproc)" --output-on-failure -LE slow ;;
  *)
    echo "scripts/test.sh: unknown option '$1' (--all, --sanitize)" >&2; exit 2 ;;
esac
