#!/usr/bin/env bash
# Benchmark of the mesher (docs/benchmarks.md): `rectify mesh` at the default
# resolution across the openings 2-1210 um, pinned to one core. Prints a
# markdown table: opening, cells, vertices, wall time (the mesher's own, and
# the whole command with its VTU/msh output), peak memory.
#   bash bench/mesh_openings.sh [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/rectify-bench-mesh}
rm -rf "$out"
mkdir -p "$out"
echo "| opening [um] | cells | vertices | gap cells | TetGen cells | mesher [s] | command with files [s] | peak memory [MB] |"
echo "|---:|---:|---:|---:|---:|---:|---:|---:|"
for um in 2 5 10 20 50 100 200 500 1000 1210; do
  /usr/bin/time -f "%e %M" -o "$out/time-$um" taskset -c 0 \
    build/bin/rectify mesh --opening "${um}um" --out "$out/$um" > /dev/null 2>&1
  read -r wall kb < "$out/time-$um"
  python3 - "$out/$um/summary.json" "$um" "$wall" "$kb" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print(f"| {sys.argv[2]} | {s['n_cells']} | {s['n_vertices']} | {s['regions']['gap']['n_cells']} | "
      f"{s['regions']['bulk']['n_cells']} | {s['wall_time_s']:.2f} | {float(sys.argv[3]):.2f} | {int(sys.argv[4]) / 1024:.0f} |")
PY
done
