#!/usr/bin/env bash
# End to end on a record rectify's model did not make (issue 17): the
# independent bench (bench/foreign/, Python + SciPy: two reed modes, a penalty
# seat, a distributed outlet line, sensor lags, coloured noise, drift, a
# distorted drive, the baseline's uncertain parameters drawn at random)
# hides a leak of 4e11 Pa s/m^3 in a record that starts mid-operation;
# `rectify diagnose`, run as a user would (reference case, all candidates),
# must name valve_leakage with R within 20 %, say how much it explains, and not
# simulate the record from rest (record, steady or periodic: each estimates its state).
#   tests/foreign_bench.sh RECTIFY SOURCE_DIR SCRATCH_DIR
set -euo pipefail
rectify=$1 src=$2 out=$3
py=python3
[ -x /usr/bin/python3 ] && py=/usr/bin/python3
rm -rf "$out" && mkdir -p "$out"
"$py" "$src/bench/foreign/make_record.py" --effect valve_leakage --value 4e11 --seed 4242 \
  --scenario no-flow --frequency 100 --start mid --cycles 12 --out "$out/record"
"$rectify" diagnose --data "$out/record/data.csv" --out "$out/d" > "$out/diagnose.log" 2>&1 ||
  { cat "$out/diagnose.log"; exit 1; }
"$py" - "$out" <<'PY'
import json, sys
out = sys.argv[1]
s = json.load(open(f"{out}/d/summary.json"))
t = json.load(open(f"{out}/record/truth.json"))
R = s["parameters"].get("leak_resistance_Pa_s_per_m3")
print("named", s["effect"], "R", R, "truth", t["value"], "verdict", s["verdict"], "-", s["verdict_sentence"])
print("start", s["localisation"][0]["start"], "(bench:", t["start"] + ")")
ok = s["effect"] == "valve_leakage" and R is not None and abs(R / t["value"] - 1) < 0.2
ok = ok and s["verdict"] in ("explained", "partly explained") and s["explained_fraction"] > 0.8
ok = ok and s["localisation"][0]["start"] != "rest"  # the record starts mid-operation
sys.exit(0 if ok else 1)
PY
