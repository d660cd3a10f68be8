#!/usr/bin/env bash
# Whether two builds of rectify compute the system model to the same bits
# with each effect on (a restructuring of system/ must not move a digit):
# `rectify synth` without noise for every effect of the library in both
# scenarios (the coil's with a voltage drive), and `rectify simulate` on a
# case with seven effects on at once; every output file compared byte for
# byte, except the lines that name the build or the time. (Known: since the
# seal became a component, a summary's high_side_capacitance_m3_per_Pa
# includes the seal's compliance; since the outlet line became one, a
# summary's model constants hold the line's node capacitance and added
# length only with the line on.)
#   bash bench/model_bits.sh OLD/rectify NEW/rectify [OUT]
set -euo pipefail
old=$1 new=$2 out=${3:-runs/model-bits}
cd "$(dirname "$0")/.."
rm -rf "$out" && mkdir -p "$out"
effects=$("$new" synth --help | sed -n 's/.*none or one of \(.*\)$/\1/p' | tr -d ',')
# several effects at once, on the reference case's own lines
sed -e 's/^leak_resistance_Pa_s_per_m3 = 0.0/leak_resistance_Pa_s_per_m3 = 3e12/' \
    -e 's/^leak_area_m2 = 0.0 /leak_area_m2 = 2e-8 /' \
    -e 's/^orifice_discharge_coefficient = 0.0/orifice_discharge_coefficient = 0.6/' \
    -e 's/^seal_compliance_m3_per_Pa = 0.0/seal_compliance_m3_per_Pa = 2e-13/' \
    -e 's/^coulomb_friction_N = 0.0/coulomb_friction_N = 5.0/' \
    -e 's/^free_air_fraction = 0.0 /free_air_fraction = 2e-3 /' \
    -e 's/^outlet_inertance_Pa_s2_per_m3 = 0.0 /outlet_inertance_Pa_s2_per_m3 = 3e6 /' \
    -e 's/^outlet_line_segments = 1 /outlet_line_segments = 3 /' \
    cases/reference.toml > "$out/combined.toml"
cp cases/thesis-resistance.csv "$out/"
compare() { # label, then the two folders
  local bad=0
  for f in "$2"/*; do
    local g="$3/$(basename "$f")"
    case "$f" in *.png|*.svg) continue ;; esac
    if ! diff -q <(grep -v '"revision"\|"version"\|wall\|elapsed\|_time_s"\|"date"\|"out"\|"case"' "$f") \
                 <(grep -v '"revision"\|"version"\|wall\|elapsed\|_time_s"\|"date"\|"out"\|"case"' "$g") > /dev/null; then
      echo "DIFFERS: $1 $(basename "$f")"; bad=1
    fi
  done
  [ $bad = 0 ] && echo "same: $1"
  return 0
}
for scenario in no-flow loaded; do
  for effect in none $effects; do
    refused=""
    for which in old new; do
      bin=$old; [ $which = new ] && bin=$new
      "$bin" synth --effect "$effect" --scenario "$scenario" --noise 0 --cycles 12 --frequency 150 \
        --out "$out/$which/synth-$scenario-$effect" > /dev/null 2>&1 || refused+="$which "
    done
    if [ -n "$refused" ]; then # an effect the scenario cannot show (friction, no-flow)
      [ "$refused" = "old new " ] && echo "refused by both: synth $scenario $effect" ||
        echo "DIFFERS: synth $scenario $effect refused by $refused"
      continue
    fi
    compare "synth $scenario $effect" "$out/old/synth-$scenario-$effect" "$out/new/synth-$scenario-$effect"
  done
  for which in old new; do
    bin=$old; [ $which = new ] && bin=$new
    "$bin" simulate --case "$out/combined.toml" --scenario "$scenario" --frequency 150 --cycles 12 \
      --out "$out/$which/combined-$scenario" > /dev/null 2>&1 || echo "failed: $which combined $scenario"
  done
  compare "simulate combined $scenario" "$out/old/combined-$scenario" "$out/new/combined-$scenario"
done
