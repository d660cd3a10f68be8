#!/usr/bin/env bash
# Benchmark of the diagnosis workflow (issue 4): 4 measured runs of 20
# pumping cycles each (synthetic: a hidden valve leak, 1 % noise, at 50, 75,
# 100 and 150 Hz), every candidate effect, all cores. Target: under 5 minutes
# on 2 cores. Prints the wall time and the named effect; the record goes to
# docs/benchmarks.md by hand.
#   bash bench/diagnosis_bench.sh [build/bin/rectify] [out-dir]
set -euo pipefail
rectify=${1:-build/bin/rectify}
out=${2:-runs/bench-diagnosis}
rm -rf "$out"
mkdir -p "$out"
data=()
for f in 50 75 100 150; do
  "$rectify" synth --effect valve_leakage --param leak_resistance_Pa_s_per_m3=5e11 --noise 0.01 \
    --seed "$f" --frequency "$f" --cycles 20 --out "$out/run-$f" > /dev/null 2>&1
  data+=("$out/run-$f/data.csv")
done
start=$(date +%s.%N)
# synth's records come from the case's one-mode reed: the baseline keeps it
"$rectify" diagnose --data "${data[@]}" --reed-second-mode case --out "$out/diagnosis" 2> "$out/diagnose.log" | tee "$out/diagnose.out"
end=$(date +%s.%N)
echo "wall time: $(echo "$end - $start" | bc) s for 4 runs x 20 cycles, all candidates, $(nproc) cores"
