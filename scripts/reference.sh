#!/usr/bin/env bash
# Sets up (scripts/setup.sh) and runs the main job on the reference case: the
# thesis's chapter-5 simulations with the lumped EHA model, into runs/reference/
#   no-flow/trace-{5,10,25,50}Hz   pressure traces, 20 A p-p / 10 A bias (Figs. 5.1, 5.2)
#   no-flow/stored-pressure        1-1200 Hz, 4 A p-p / 2 A bias, dynamic and ideal valves (Fig. 5.3)
#   loaded/velocity                10-3500 Hz, 50 lb, dynamic, ideal, reed what-if (Figs. 5.4-5.6)
#   loaded/trace-1420Hz            the phase lag of Fig. 5.5
#   stiffness                      the reed's stiffness, shape and modes (sec. 3.1.3)
#   mesh-100um                     the valve's fluid mesh at 100 um tip opening (VTU, msh, quality)
#   flow-100um                     Stokes flow at 100 um: R, force on the reed, thin-gap theory, VTU
#   diagnosis                      a synthetic run with a hidden valve leak, and `diagnose` naming it
#   map-set                        the valve's own FE maps (`rectify design`, ~4 min on 2 cores): the reed's
#                                  k_r, m_r, shape; R(x) and A_eff(x) from Stokes flow on that shape
#   fe-maps/...                    the chapter-5 runs again, the model on those FE maps (docs/chapter5-comparison.md)
#   fe-loading/...                 and once more with the reed's fluid loading from the map set: squeeze film
#                                  (its suction limited by cavitation), added mass, displaced flow
#                                  (docs/fluid-loading.md)
#   fe-loading-film20um/...        the same with a 20 um residual film on the seat
#   thesis-model/...               the chapter-5 runs on the thesis's R(x) with the thesis's own model:
#                                  no stop, no cavitation (--thesis-model), for the comparison
# Every run above has the reed's stop and the oil's cavitation (docs/system-model.md) and says
# whether its state is one the hardware can reach (validity, docs/stress.md).
#   (scripts/film_study.sh runs the other film variants of docs/fluid-loading.md)
# Interrupted? Run it again: finished sweep points are kept and not redone.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
rectify=build/bin/rectify
out=runs/reference
mpi=(mpirun -np "$(nproc)")
[ "$(id -u)" -ne 0 ] || mpi=(mpirun --allow-run-as-root -np "$(nproc)")

# The valve's own maps first: every run below is made twice, on the thesis's R(x) and on these.
"${mpi[@]}" $rectify design --out $out/map-set
for f in 5 10 25 50; do
  $rectify simulate --scenario no-flow --frequency $f --cycles 5 --out $out/no-flow/trace-${f}Hz
done
$rectify sweep --scenario no-flow --current-pp 4 --current-bias 2 --from 1 --to 1200 --n 40 \
  --spacing log --out $out/no-flow/stored-pressure
$rectify sweep --scenario loaded --from 10 --to 3500 --n 100 --spacing linear \
  --out $out/loaded/velocity
$rectify simulate --scenario loaded --frequency 1420 --cycles 300 --out $out/loaded/trace-1420Hz
$rectify stiffness --out $out/stiffness
$rectify mesh --opening 100um --out $out/mesh-100um
$rectify stokes --opening 100um --out $out/flow-100um
$rectify synth --effect valve_leakage --noise 0.01 --seed 1 --frequency 100 --cycles 20 \
  --out $out/diagnosis/data-leak
$rectify diagnose --data $out/diagnosis/data-leak/data.csv --out $out/diagnosis/result
# Chapter 5 on the FE maps: R(x), A_eff(x), k_r and m_r from the map set.
fe=(--map-set $out/map-set)
for f in 5 10 25 50; do
  $rectify simulate "${fe[@]}" --scenario no-flow --frequency $f --cycles 5 --out $out/fe-maps/no-flow/trace-${f}Hz
done
$rectify sweep "${fe[@]}" --scenario no-flow --current-pp 4 --current-bias 2 --from 1 --to 1200 --n 40 \
  --spacing log --out $out/fe-maps/no-flow/stored-pressure
$rectify sweep "${fe[@]}" --scenario loaded --from 10 --to 3500 --n 100 --spacing linear \
  --out $out/fe-maps/loaded/velocity
$rectify simulate "${fe[@]}" --scenario loaded --frequency 1420 --cycles 300 --out $out/fe-maps/loaded/trace-1420Hz
# And with the reed's fluid loading from the same map set (docs/fluid-loading.md:
# the squeeze film's suction limited by cavitation; tighter tolerances; a sweep
# point CVODE cannot finish is recorded as failed, NaN, and the sweep goes on),
# without and with a 20 um residual film on the seat.
loading_set() {
  local d=$1; shift
  local fl=(--map-set $out/map-set --fluid-loading map "$@")
  for f in 5 10 25 50; do
    $rectify simulate "${fl[@]}" --rtol 1e-6 --scenario no-flow --frequency $f --cycles 5 \
      --out $d/no-flow/trace-${f}Hz
  done
  $rectify sweep "${fl[@]}" --rtol 1e-7 --scenario no-flow --current-pp 4 --current-bias 2 --from 1 \
    --to 1200 --n 40 --spacing log --out $d/no-flow/stored-pressure
  $rectify sweep "${fl[@]}" --rtol 1e-6 --scenario loaded --from 10 --to 3500 --n 100 --spacing linear \
    --out $d/loaded/velocity
  $rectify simulate "${fl[@]}" --rtol 1e-6 --scenario loaded --frequency 1420 --cycles 300 \
    --out $d/loaded/trace-1420Hz
}
loading_set $out/fe-loading
loading_set $out/fe-loading-film20um --seat-film-m 2e-5
# The thesis's model as it was: no stop, no cavitation.
th=$out/thesis-model
for f in 5 10 25 50; do
  $rectify simulate --thesis-model --scenario no-flow --frequency $f --cycles 5 --out $th/no-flow/trace-${f}Hz
done
$rectify sweep --thesis-model --scenario no-flow --current-pp 4 --current-bias 2 --from 1 --to 1200 --n 40 \
  --spacing log --out $th/no-flow/stored-pressure
$rectify sweep --thesis-model --scenario loaded --from 10 --to 3500 --n 100 --spacing linear --out $th/loaded/velocity
$rectify simulate --thesis-model --scenario loaded --frequency 1420 --cycles 300 --out $th/loaded/trace-1420Hz
python3 scripts/chapter5_numbers.py $out "FE maps + loading, 20 um seat film=$out/fe-loading-film20um" \
  "thesis's model (no stop, no cavitation)=$th" > $out/chapter5-numbers.md
echo "reference case done: see $out/*/*/summary.json and the PNG plots beside them"
