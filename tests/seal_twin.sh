#!/usr/bin/env bash
# What a no-flow record can tell of a soft seal (issue 17; docs/diagnosis.md,
# "Limits"): the independent bench's seal record (bench/foreign, the study's
# outlet_compliance-2 rig, seed 19534: a 2.85e-14 m^3/Pa seal, 100 Hz, from
# rest, 6 cycles) against its twin whose extra compliance is oil (the same
# rig and draws, the column longer by C_seal beta / (A_po xi_h): 0.2995 m,
# within the reference case's declared 0.3 m), compared by
# bench/foreign/seal_twin.py in units of the record's white noise:
#   - the seal without its lip (its compliance follows the high side at
#     once, as the library's seal does) and the twin: below 0.3 units in every
#     column and sample (measured 0.04-0.11): the same record to the noise;
#   - the bench's seal with its 0.1 ms lip and the twin: the valve's opening
#     above 3 units within 10 harmonics (measured 7.3): the lip is what
#     tells the seal from oil.
# Usage: seal_twin.sh SOURCE_DIR SCRATCH
set -euo pipefail
src=$1 out=$2
py=python3
[ -x /usr/bin/python3 ] && py=/usr/bin/python3
rm -rf "$out" && mkdir -p "$out"
common=(--effect outlet_compliance --seed 19534 --cycles 6)
"$py" "$src/bench/foreign/make_record.py" "${common[@]}" --out "$out/seal" & seal=$!
"$py" "$src/bench/foreign/make_record.py" "${common[@]}" --without lip --out "$out/no-lip" & no_lip=$!
"$py" "$src/bench/foreign/make_record.py" "${common[@]}" --seal-as-oil --out "$out/oil"
wait $seal
wait $no_lip
"$py" "$src/bench/foreign/seal_twin.py" "$out/no-lip" "$out/oil" "$out/seal" "$out/oil" --json "$out/twin.json"
"$py" - "$out/twin.json" <<'PY'
import json, sys
no_lip, lip = json.load(open(sys.argv[1]))
bad = []
if not no_lip["within_reach"]:
    bad.append(f"the twin's column {no_lip['twin_wet_l']:.4f} m is beyond the case's bound")
for c, v in no_lip["columns"].items():
    print(f"without the lip: {c}: {v['every_sample']:.3f} noise units (limit 0.3)")
    if not v["every_sample"] < 0.3:
        bad.append(f"without the lip, {c} differs by {v['every_sample']:.3f}")
valve = lip["columns"]["outlet_valve_m"]["within_10_harmonics"]
print(f"with the lip: outlet_valve_m: {valve:.3f} noise units within 10 harmonics (at least 3)")
if not valve > 3:
    bad.append(f"with the lip the valve differs by only {valve:.3f}")
if bad:
    sys.exit("seal_twin: " + "; ".join(bad))
PY
