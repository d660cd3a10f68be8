#!/usr/bin/env bash
# How many of the reference job's loaded runs describe a state the hardware
# can reach (docs/benchmarks.md, "Validity of the reference runs"): the loaded
# velocity sweep (10-3500 Hz, 100 points, three series) and the 1420 Hz trace
# of scripts/reference.sh, for each of its four models - the thesis's R(x),
# the FE maps, the FE maps with the reed's fluid loading, and the same with a
# 20 um seat film - twice: with the thesis's model as it was before the stop
# and cavitation existed (--thesis-model, on a map set that ends at 1.21 mm
# as the reference's did) and as it is (the stop, cavitation, the map set to
# the stop). Prints a Markdown table of the counts and the 1420 Hz states.
#   bash bench/reference_validity.sh OLD_MAP_SET MAP_SET OUT
# OLD_MAP_SET: `rectify design` of the reference case with [design]
# openings_to_m = 1210e-6; MAP_SET: of the reference case as it is.
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -eq 3 ] || { echo "usage: bash bench/reference_validity.sh OLD_MAP_SET MAP_SET OUT" >&2; exit 2; }
old=$1 new=$2 out=$3
rectify=${RECTIFY:-build/bin/rectify}
mkdir -p "$out"
one() { # NAME MAPSET MODE [options]: the loaded sweep and the 1420 Hz trace
  local name=$1 set=$2 mode=$3; shift 3
  local o=() rtol=()
  [ "$set" = thesis ] || o=(--map-set "$set")
  [ "$mode" = before ] && o+=(--thesis-model)
  [ "$name" = thesis ] || [ "$name" = fe ] || rtol=(--rtol 1e-6)
  $rectify sweep "${o[@]}" "${rtol[@]}" "$@" --scenario loaded --from 10 --to 3500 --n 100 --spacing linear \
    --quiet --out "$out/$mode/$name/velocity" > /dev/null
  $rectify simulate "${o[@]}" "${rtol[@]}" "$@" --scenario loaded --frequency 1420 --cycles 300 \
    --out "$out/$mode/$name/trace-1420Hz" > /dev/null
}
for mode in before after; do
  set=$new
  [ $mode = before ] && set=$old
  one thesis thesis $mode
  one fe "$set" $mode
  one loading "$set" $mode --fluid-loading map
  one film20um "$set" $mode --fluid-loading map --seat-film-m 2e-5
done
python3 - "$out" <<'EOF'
import csv, json, sys
from pathlib import Path
out = Path(sys.argv[1])
names = {'thesis': 'thesis R(x)', 'fe': 'FE maps', 'loading': 'FE maps + fluid loading', 'film20um': '+ 20 um seat film'}
print('| model | runs | not valid: before -> after | beyond map | through stop | below cavitation | Goodman < 1 | '
      '1420 Hz max outlet / inlet opening [mm] | 1420 Hz min abs chamber p [MPa] | 1420 Hz samples beyond map |')
print('|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|')
for key, label in names.items():
    cells = {}
    for mode in ('before', 'after'):
        rows = [r for r in csv.DictReader(open(out / mode / key / 'velocity' / 'sweep-runs.csv'))
                if not r['regime'].startswith('failed')]
        count = lambda k: sum(r[k] == '1' for r in rows)
        run = json.load(open(out / mode / key / 'trace-1420Hz' / 'summary.json'))['run']
        cells[mode] = dict(n=len(rows), bad=sum(r['valid'] != '1' for r in rows),
                           flags=[count(k) for k in ('beyond_map', 'beyond_stop', 'below_cavitation_pressure',
                                                      'goodman_below_1')],
                           trace='{:.2f} / {:.2f} | {:.2f} | {}'.format(
                               run['max_outlet_reed_opening_m'] * 1e3, run['max_inlet_reed_opening_m'] * 1e3,
                               run['min_absolute_chamber_pressure_Pa'] * 1e-6, run['samples_beyond_map']))
    b, a = cells['before'], cells['after']
    flags = ' | '.join(f'{x} -> {y}' for x, y in zip(b['flags'], a['flags']))
    print(f"| {label} | {a['n']} | {b['bad']} -> {a['bad']} | {flags} | {b['trace'].split(' | ')[0]} -> "
          f"{a['trace'].split(' | ')[0]} | {b['trace'].split(' | ')[1]} -> {a['trace'].split(' | ')[1]} | "
          f"{b['trace'].split(' | ')[2]} -> {a['trace'].split(' | ')[2]} |")
EOF
