#!/usr/bin/env bash
# Benchmark of `rectify design` (docs/benchmarks.md): the reference case's
# whole map set (reed solve, meshes on its FE shape, Stokes at every opening
# the 0.5 % interpolation tolerance needs), on all cores, from scratch.
# Prints the wall time, the openings, the achieved interpolation error and
# the time per phase from the manifest.
#   bash bench/design_map_set.sh [OUT] [NPROCS]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/rectify-bench-design}
np=${2:-$(nproc)}
rm -rf "$out"
mpi=(mpirun -np "$np")
[ "$(id -u)" -ne 0 ] || mpi=(mpirun --allow-run-as-root -np "$np")
start=$(date +%s.%N)
"${mpi[@]}" build/bin/rectify design --out "$out" > "$out.log" 2>&1 || { cat "$out.log"; exit 1; }
end=$(date +%s.%N)
python3 - "$out/manifest.json" "$start" "$end" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
wall = float(sys.argv[3]) - float(sys.argv[2])
pts = m['points']
solve = sum(p['wall_time_s'] for p in pts)
e = m['interpolation_error']
print(f"wall {wall:.0f} s on {m['settings']['n_processes']} processes: reed {m['stiffness_wall_time_s']:.1f} s, "
      f"{len(pts)} openings, Stokes solves {solve:.0f} s (set-up, assembly, solve), the rest meshing and I/O; "
      f"interpolation error R {100*e['R_max_rel']:.2f} %, A_eff {100*e['A_eff_max_rel']:.2f} % "
      f"(tolerance {100*e['tolerance']:.1f} %), converged {e['converged']}")
PY
