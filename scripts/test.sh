#!/usr/bin/env bash
# Sets up (scripts/setup.sh) and runs the default test suite. Slow cases carry
# the ctest label "slow" and run only with: scripts/test.sh --all
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cd build
if [ "${1:-}" = "--all" ]; then
  ctest -j"$(nproc)" --output-on-failure
else
  ctest -j"$(nproc)" --output-on-failure -LE slow
fi
