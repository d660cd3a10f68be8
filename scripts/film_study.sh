#!/usr/bin/env bash
# The chapter-5 runs with the reed's fluid loading under each model of what
# ends the squeeze film at the seat (docs/fluid-loading.md, "What ends the
# film"): no limit; the film's suction limited by cavitation (the default);
# and that with a residual film of 1, 5 and 20 um on the seat. Needs a map set
# with loading.csv (scripts/reference.sh makes runs/reference/map-set), about
# 3 min per variant on 2 cores. Interrupted? Run it again: finished sweep
# points are kept.
#   usage: scripts/film_study.sh [MAP_SET] [OUT]
set -euo pipefail
cd "$(dirname "$0")/.."
map_set=${1:-runs/reference/map-set}
out=${2:-runs/film-study}
rectify=build/bin/rectify
[ -f "$map_set/loading.csv" ] || { echo "film_study.sh: $map_set has no loading.csv (run scripts/reference.sh)" >&2; exit 2; }
variant() {
  local label=$1; shift
  local fl=(--map-set "$map_set" --fluid-loading map "$@") d=$out/$label
  for f in 5 10 25 50; do
    $rectify simulate "${fl[@]}" --rtol 1e-6 --scenario no-flow --frequency $f --cycles 5 \
      --out $d/no-flow/trace-${f}Hz > /dev/null
  done
  $rectify sweep "${fl[@]}" --rtol 1e-7 --scenario no-flow --current-pp 4 --current-bias 2 --from 1 --to 1200 \
    --n 40 --spacing log --quiet --out $d/no-flow/stored-pressure
  $rectify sweep "${fl[@]}" --rtol 1e-6 --scenario loaded --from 10 --to 3500 --n 100 --spacing linear \
    --quiet --out $d/loaded/velocity
  $rectify simulate "${fl[@]}" --rtol 1e-6 --scenario loaded --frequency 1420 --cycles 300 \
    --out $d/loaded/trace-1420Hz > /dev/null
  echo "film_study.sh: $label done"
}
variant no-limit --film-suction-limit none
variant cavitation
variant cavitation-film1um --seat-film-m 1e-6
variant cavitation-film5um --seat-film-m 5e-6
variant cavitation-film20um --seat-film-m 2e-5
python3 scripts/chapter5_numbers.py runs/reference "no limit=$out/no-limit" "cavitation=$out/cavitation" \
  "cavitation, 1 um film=$out/cavitation-film1um" "cavitation, 5 um film=$out/cavitation-film5um" \
  "cavitation, 20 um film=$out/cavitation-film20um" > $out/chapter5-film-numbers.md
echo "film_study.sh: the table is $out/chapter5-film-numbers.md"
