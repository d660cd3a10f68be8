#!/usr/bin/env bash
# Benchmark of `rectify whatif` (docs/benchmarks.md, docs/whatif.md): the
# reference what-ifs on the reference case, from an empty map-set cache.
#   bash bench/whatif_batch.sh thickness|port|coarse [OUT] [NPROCS]
#     thickness  reed thickness 0.08-0.25 mm, 10 designs
#     port       port diameter 2.0-4.0 mm, 5 designs
#     coarse     the tests' coarse valve, 3 thicknesses (for the -np 1 / -np 2 speed-up)
# Prints the wall time and, from jobs.log, the jobs' summed time per kind
# (what one process would need with no waiting) and the speed-up it implies.
set -euo pipefail
cd "$(dirname "$0")/.."
what=${1:?thickness, port or coarse}
out=${2:-/tmp/rectify-bench-whatif-$what}
np=${3:-$(nproc)}
rm -rf "$out" "$out-cache"
mpi=(mpirun -np "$np")
[ "$(id -u)" -ne 0 ] || mpi=(mpirun --allow-run-as-root -np "$np")
case_args=()
case $what in
  # [mesh] gap_cutoff_ratio 0.03 (the case's 0.05): at 1.21 mm tip opening the
  # 0.08 mm reed's cut-off gap would not be thinner than the reed (the mesher
  # refuses it); one setting for every design of the study.
  thickness) vary=(--vary geometry.reed_thickness_m=0.08e-3:0.25e-3:10 --vary mesh.gap_cutoff_ratio=0.03:0.03:1) ;;
  port) vary=(--vary geometry.port_diameter_m=2.0e-3:4.0e-3:5 --vary mesh.gap_cutoff_ratio=0.03:0.03:1) ;;
  coarse)
    mkdir -p "$out-cache"
    cat > "$out-cache/coarse.toml" <<'TOML'
[mesh]
size_reed_m = 0.5e-3
size_far_m = 1.5e-3
station_spacing_m = 0.4e-3
gap_layers = 2
reed_layers = 1
above_layers = 1
port_layer_m = 1e-3
[flow]
solver = "direct"
[stiffness]
cells_along_length = 12
cells_across_width = 10
cells_through_thickness = 1
n_modes = 1
[design]
openings_from_m = 10e-6
openings_to_m = 300e-6
initial_openings = 3
tolerance = 0.02
TOML
    case_args=(--case "$out-cache/coarse.toml")
    vary=(--vary geometry.reed_thickness_m=0.1e-3:0.2e-3:3) ;;
  *) echo "unknown what-if '$what'" >&2; exit 2 ;;
esac
start=$(date +%s.%N)
"${mpi[@]}" build/bin/rectify whatif "${case_args[@]}" "${vary[@]}" --cache "$out-cache" --out "$out" \
  > "$out.log" 2>&1 || { tail -30 "$out.log"; exit 1; }
end=$(date +%s.%N)
python3 - "$out/jobs.log" "$start" "$end" "$np" <<'PY'
import re, sys, collections
wall = float(sys.argv[3]) - float(sys.argv[2])
np_ = int(sys.argv[4])
total = collections.defaultdict(float); count = collections.Counter()
for line in open(sys.argv[1]):
    m = re.search(r' done ([a-z-]+):\S+ rank \d+ ([0-9.]+) s', line)
    if m:
        total[m.group(1)] += float(m.group(2)); count[m.group(1)] += 1
s = sum(total.values())
print(f"wall {wall:.0f} s on {np_} processes; jobs: " +
      ", ".join(f"{k} {count[k]} x {total[k]/count[k]:.1f} s = {total[k]:.0f} s" for k in sorted(total)) +
      f"; summed {s:.0f} s (one process, no waiting: {s/wall:.2f}x this wall)")
PY
