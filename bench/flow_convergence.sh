#!/usr/bin/env bash
# Mesh convergence of R(x) (docs/stokes.md): `rectify stokes` on the flow-mesh
# levels cases/flow-levels/{A,B,C,D}.toml (each size ~1/sqrt(2) of the
# previous) at 5, 100 and 1000 um. Prints a markdown table with R from mean
# pressures and from dissipation, A_eff, DoFs, iterations, wall time and peak
# memory, and each level's change against the previous one.
#   bash bench/flow_convergence.sh [OUT] [LEVELS] [OPENINGS] [NP]
# e.g. bash bench/flow_convergence.sh /tmp/conv "A B C" "5 100 1000" 2
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/rectify-flow-convergence}
levels=${2:-A B C D}
openings=${3:-5 100 1000}
np=${4:-1}
mkdir -p "$out"
run=(build/bin/rectify)
[ "$np" -gt 1 ] && run=(mpirun --allow-run-as-root -np "$np" build/bin/rectify)
echo "| opening [um] | level | DoFs | R (pressures) [Pa s/m^3] | change | R (dissipation) | change | A_eff [mm^2] | iterations | wall [s] | peak memory [GB] |"
echo "|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for um in $openings; do
  prev=""
  for level in $levels; do
    dir="$out/$level-$um"
    if [ ! -f "$dir/summary.json" ]; then # finished runs are kept: the study resumes
      /usr/bin/time -f "%e %M" -o "$out/time-$level-$um" "${run[@]}" stokes --case "cases/flow-levels/$level.toml" \
        --opening "${um}um" --no-vtu --out "$dir" > "$out/log-$level-$um" 2>&1
    fi
    read -r wall kb < "$out/time-$level-$um"
    python3 - "$dir/summary.json" "$um" "$level" "$wall" "$kb" "$prev" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
prev = json.load(open(sys.argv[6])) if sys.argv[6] else None
def change(key):
    return f"{100 * (s[key] / prev[key] - 1):+.2f} %" if prev else ""
# peak memory: one process's maximum resident set (GNU time), times the processes
print(f"| {sys.argv[2]} | {sys.argv[3]} | {s['n_dofs']} | {s['R_Pa_s_per_m3']:.5e} | {change('R_Pa_s_per_m3')} | "
      f"{s['R_dissipation_Pa_s_per_m3']:.5e} | {change('R_dissipation_Pa_s_per_m3')} | {s['A_eff_m2'] * 1e6:.3f} | "
      f"{s['iterations']} | {float(sys.argv[4]):.1f} | {int(sys.argv[5]) / 1024**2:.2f} |")
PY
    prev="$dir/summary.json"
  done
done
