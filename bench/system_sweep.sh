#!/usr/bin/env bash
# Benchmark of the system model (docs/benchmarks.md): the velocity sweep of
# thesis Fig. 5.4, 100 frequencies 10-3500 Hz, dynamic valves, a settled
# start-up and 50 measured cycles each, on all cores. Prints the wall time and
# the per-cycle cost; the CVODE statistics are in OUT/sweep-runs.csv.
#   bash bench/system_sweep.sh [OUT] [extra sweep options...]
# RECTIFY=path/to/rectify runs another build (e.g. a copy of an older one, to
# compare with bench/compare_sweeps.py).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/rectify-bench-sweep}
shift || true
rm -rf "$out"
start=$(date +%s.%N)
${RECTIFY:-build/bin/rectify} sweep --scenario loaded --from 10 --to 3500 --n 100 --spacing linear \
  --series dynamic --quiet --out "$out" "$@"
end=$(date +%s.%N)
awk -F, -v start="$start" -v end="$end" 'NR > 1 {
    cycles += $8 + $9; cpu += $10; steps += $12; rhs += $13; jac += $14; events += $15 }
  END { printf "wall %.1f s, %d cycles, CPU %.1f s = %.2f ms per cycle, %.0f CVODE steps per cycle, %.1f rhs per step, %.1f steps per Jacobian, %.1f events per cycle\n",
        end - start, cycles, cpu, 1000 * cpu / cycles, steps / cycles, rhs / steps, steps / jac, events / cycles }' "$out/sweep-runs.csv"
