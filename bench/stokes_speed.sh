#!/usr/bin/env bash
# The Stokes solve's speed (docs/benchmarks.md, "The Stokes solve's speed"):
# one solve of the reference valve at 100 um on one process, with PETSc's
# log of where the time goes (set-up, assembly, the velocity AMG's cycles,
# the Schur preconditioner, Krylov orthogonalisation), the FGMRES
# iterations of each solve and the AMG hierarchies' complexity; then the
# reference map set on NPROCS processes, its wall time and peak memory.
#   bash bench/stokes_speed.sh [OUT] [NPROCS]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/rectify-bench-stokes}
np=${2:-$(nproc)}
rm -rf "$out" && mkdir -p "$out"
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
PETSC_OPTIONS="-rectify_ksp_converged_reason -log_view :$out/log_view.txt \
 -rectify_fieldsplit_u_pc_hypre_boomeramg_print_statistics 1" \
  /usr/bin/time -v build/bin/rectify stokes --opening 100um --no-vtu --out "$out/flow100" > "$out/flow100.log" 2>&1
echo "one solve at 100 um, one process:"
grep -E "^  flow:|^  loading:" "$out/flow100.log"
grep -E "rectify_ solve converged" "$out/flow100.log" | awk '{print "  FGMRES iterations:", $NF}'
grep -E "operator = " "$out/flow100.log" | head -1 | awk '{print "  velocity AMG operator complexity:", $NF}'
grep -E "^(KSPSolve_FS_0|KSPSolve_FS_Schu|KSPGMRESOrthog|PCSetUp  ) " "$out/log_view.txt" |
  awk '{printf "  %-18s %5d calls %8.2f s\n", $1, $2, $4}'
grep -E "Maximum resident" "$out/flow100.log" | awk '{printf "  peak memory %.2f GB\n", $NF / 1e6}'
mpi=(mpirun -np "$np")
[ "$(id -u)" -ne 0 ] || mpi=(mpirun --allow-run-as-root -np "$np")
start=$(date +%s.%N)
/usr/bin/time -v "${mpi[@]}" build/bin/rectify design --out "$out/map-set" > "$out/design.log" 2>&1
end=$(date +%s.%N)
python3 - "$out/map-set/manifest.json" "$start" "$end" "$out/design.log" <<'PY'
import json, re, sys
m = json.load(open(sys.argv[1]))
pts = m['points']
rss = re.search(r'Maximum resident set size \(kbytes\): (\d+)', open(sys.argv[4]).read())
print(f"map set on {m['settings']['n_processes']} processes: {float(sys.argv[3]) - float(sys.argv[2]):.0f} s wall, "
      f"{len(pts)} openings, peak memory per process {int(rss.group(1)) / 1e6:.2f} GB")
for k in ['mesh_time_s', 'setup_time_s', 'assembly_time_s', 'solve_time_s', 'loading_time_s', 'wall_time_s']:
    v = [p[k] for p in pts]
    print(f"  {k:16s} sum {sum(v):7.1f} s, per opening {sum(v) / len(v):5.2f} s")
its = [p['iterations'] for p in pts]
print(f"  FGMRES iterations (flow + moving reed) {min(its):.0f}-{max(its):.0f}, {sum(its):.0f} in all")
PY
