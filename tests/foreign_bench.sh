#!/usr/bin/env bash
# End to end on a record rectify's model did not make (issue 17): the
# independent bench (bench/foreign/, Python + SciPy: two reed modes, a penalty
# seat, a distributed outlet line, sensor lags, coloured noise, drift, a
# distorted drive, the baseline's uncertain parameters drawn at random)
# hides a leak in a record that starts mid-operation - laminar (4e11 Pa s/m^3)
# or turbulent (an orifice of 6e-8 m^2, the bench's own formula); `rectify
# diagnose`, run as a user would (reference case, all candidates, both leak
# forms among them), must name the leak in its right form with its parameter
# within 20 %, say how much it explains, and not simulate the record from rest
# (record, steady or periodic: each estimates its state). Form `line`: the
# study's line_inertance-0, a 0.74 m hose on the outlet (3.14e7 Pa s^2/m^3 in
# the bench's 37 sections; its bore and the oil column drawn away from the
# case's), a record from rest at 100 Hz: named, L within 20 %, at most 2
# noise units left. Form `line-short`: the study's line_inertance-2, a 0.32 m
# hose (2.95e7 Pa s^2/m^3 in 17 sections; the oil column a third of the
# case's, the bore 4.03 mm for 4.57) at 150 Hz from rest, whose line basin
# the grid along the valley of constant ringing missed: named, L within
# 20 %; its start-up leaves more than 2 noise units, so the verdict must say
# "partly explained" there, and what it explains must pass the naming rule
# (half the gap). Form `mid-start`: the study's valve_leakage_turbulent-0 (a
# turbulent leak of 1.0e-7 m^2 in a record from mid-operation at 100 Hz),
# whose start every start scores alike with the case's baseline: the start
# is chosen again with the named leak, and what remains is within 2 noise
# units. Form `passage`: the study's coil_dynamics-1 (a coil of 1.37 mH,
# voltage drive, no-flow at 100 Hz from rest), whose residual after the
# coil stayed at 2.9 noise units while the bench's 1 cm outlet passage
# (which the reference case leaves out) was missing from the model: the
# passage, declared uncertain in the reference case, is tried on at the
# coil's fit and kept, within a factor 1.5 of the
# bench's 4/3 rho l / A (the model's one lumped section stands for the
# bench's distributed passage), and at most 2 noise units remain. Form
# `near-miss`: the study's orifice_flow-2 (a loaded record at 100 Hz from its
# static state, Cd 0.468 behind the reed), where without the passage the
# orifice closes 49.6 % of the gap against none refitted from its baseline
# (50 % needed; against none from the case's values, before that refit, it
# closed 50.4 % but too little of the dominant feature, the outlet valve's
# refill half) and nothing is named: the passage is tried on at none's fit and at the
# orifice's, the orifice is judged again against none with it and named, Cd
# within 20 %, at most 2 noise units left, and what it closed without the
# passage is reported (at least the 20 % that earns the try), with the rule
# it failed. Form `coil-mid`: the study's
# coil_dynamics-2 (a coil of 2.02 mH, its corner at the pumping frequency,
# 150 Hz, voltage drive, no-flow, a record from mid-operation): the record
# start takes the coil's periodic current (it had started at V(0)/R, and
# the first cycle's wrong force pumped oil into the blocked outlet that
# drained over the whole record: 9.4 noise units left, L 6 % low): named,
# L within 20 %, at most 2 noise units left. Form `friction`: the study's
# piston_friction-1 (loaded, 100 Hz, from rest; the bench's seal friction
# is Coulomb's with a 30 % Stribeck rise and a sharper sign than the case's
# tanh): the friction's shape, declared [uncertain] in the reference case,
# is held out of every fit while the model has no friction and freed at
# the named friction's fit where the data determine it: named, F_c within
# 20 %, at most 2 noise units left (2.09 with Coulomb's law alone). Form
# `long`: the laminar leak's rig in a record of 40 cycles (29 training
# cycles after the settling one), whose candidates (the leak, air, a soft
# seal) are compared on its first 12 training cycles only
# (--compared-cycles 12): the leak is still named, within 20 % and at most 2
# noise units left, every candidate scored on those 12 cycles alone (and
# the one sample more that the window may hold as dt rounds), and the
# named leak refitted on all 29 (its value and residual the whole record's).
# Form `line-moved`: the study's line_inertance-3 (a hose of L 3.31e7,
# no-flow at 100 Hz from mid-operation), whose named fit stops at 4.15e7
# (+25 %) while its profile's lower side fits far better (evidence -528): the fit
# moves there (at least one move, each with evidence below -10) and the line
# is named with L within 20 % (+2.2 % here) and at least half of the gap
# closed (74 %; 2.9 noise units are left and the verdict says "partly
# explained"; docs/diagnosis-history.md, "A profile that finds a better fit" and the
# forty-first stop). The form used line_inertance-4 until the records' CPU
# paths were pinned: made with OpenBLAS's AVX-512 kernels, its fit moved
# from +63 % to +34 %; made on the AVX2 paths it stops at +80 % in a basin
# whose profile fits worse on both sides, and nothing moves. Form `friction-rest`: the study's piston_friction-4
# (loaded, 100 Hz, from rest, Coulomb 4.6 N; the friction alone against
# none, --effects piston_friction), whose friction grid's two best points
# (0.3 and 0.7 N at the baseline's fit) are one valley: its searches start
# from the grid's two best valleys, one of them 6.8 N at the case's values,
# and the friction is named (at once, or as the nearest miss once the outlet
# passage is tried on: its first fit closes 33 % of the gap on the pinned
# record, 41 % on the AVX-512 one), F_c
# within 20 %, at most 2 noise units left.
# Made on a machine with AVX-512 its record differs from one made without
# by 1e-5 of each signal's swing, and with the two best points the friction
# was found from one and not the other (docs/diagnosis-history.md, "One start per
# valley"); records are now made on pinned CPU paths (cpu_paths.py).
# Form `none-orbit`: the study extension's none-7 (no effect, no-flow at
# 100 Hz from mid-operation; the bench's outlet valve opens 93 um every
# cycle), where none's fit from the case's values stops with the outlet valve
# shut (7.86 noise units) and a leak 2500 x weaker than the bench's weakest
# was named: none is refitted from the best candidate's baseline before any
# is judged, kept, and nothing is named, at most 2 noise units left. Every
# form checks what summary.json says of that refit against its rule.
#   tests/foreign_bench.sh RECTIFY SOURCE_DIR SCRATCH_DIR [laminar|turbulent|line|line-short|line-moved|mid-start|passage|near-miss|coil-mid|friction|friction-rest|long|none-orbit]
set -euo pipefail
rectify=$1 src=$2 out=$3 form=${4:-laminar}
max_residual=1e9 min_explained=0.8 parameter_tolerance=0.2
# where the effect leaves a gap the other candidates cannot follow, some of
# them are not restarted (diagnose.cpp, fit()); in the short hose's record
# (line_inertance-2) their grid starts lie far above none's fit, and the
# way back down promises enough that none is cut (they all end at none's
# level, in searches that end by themselves, so their restarts are short)
expect_cut=1
diagnose_args=()  # as study.py runs the record: its scenario (no-flow unless given)
at_100Hz=(--scenario no-flow --frequency 100)
case "$form" in
  laminar) effect=valve_leakage key=leak_resistance_Pa_s_per_m3
    record_args=(--value 4e11 --seed 4242 --start mid --cycles 12 "${at_100Hz[@]}") ;;
  turbulent) effect=valve_leakage_turbulent key=leak_area_m2
    record_args=(--value 6e-8 --seed 4242 --start mid --cycles 12 "${at_100Hz[@]}") ;;
  line) effect=line_inertance key=outlet_inertance_Pa_s2_per_m3
    max_residual=2 record_args=(--seed 14152 --cycles 16) ;; # the study's line_inertance-0, as study.py makes it
  line-moved) effect=line_inertance key=outlet_inertance_Pa_s2_per_m3 min_explained=0.5
    record_args=(--seed 14200 --cycles 16) ;; # the study's line_inertance-3
  line-short) effect=line_inertance key=outlet_inertance_Pa_s2_per_m3 min_explained=0.5 expect_cut=0
    record_args=(--seed 14184 --cycles 16) ;; # the study's line_inertance-2
  mid-start) effect=valve_leakage_turbulent key=leak_area_m2 max_residual=2
    record_args=(--seed 33522 --cycles 16) ;; # the study's draws, as study.py makes them: no-flow, 100 Hz, mid
  passage) effect=coil_dynamics key=coil_inductance_H max_residual=2
    record_args=(--seed 12736 --cycles 16) ;; # the study's coil_dynamics-1
  coil-mid) effect=coil_dynamics key=coil_inductance_H max_residual=2
    record_args=(--seed 12751 --cycles 16) ;; # the study's coil_dynamics-2
  friction) effect=piston_friction key=coulomb_friction_N max_residual=2
    diagnose_args=(--scenario loaded) record_args=(--seed 16206 --cycles 16) ;; # the study's piston_friction-1
  friction-rest) effect=piston_friction key=coulomb_friction_N max_residual=2 expect_cut=0
    diagnose_args=(--scenario loaded --effects piston_friction) record_args=(--seed 16257 --cycles 16) ;; # the study's piston_friction-4
  near-miss) effect=orifice_flow key=orifice_discharge_coefficient min_explained=0.5 max_residual=2
    diagnose_args=(--scenario loaded) record_args=(--seed 11280 --cycles 16) ;; # the study's orifice_flow-2
  none-orbit) effect=none key=- max_residual=2
    record_args=(--seed 3321 --cycles 16) ;; # the study's none-7 (its extension): no-flow, 100 Hz, mid
  long) effect=valve_leakage key=leak_resistance_Pa_s_per_m3 max_residual=2 expect_cut=0
    diagnose_args=(--effects valve_leakage entrained_air outlet_compliance --compared-cycles 12)
    record_args=(--value 4e11 --seed 4242 --start mid --cycles 40 "${at_100Hz[@]}") ;;
  *) echo "unknown form '$form'" >&2; exit 2 ;;
esac
py=python3
[ -x /usr/bin/python3 ] && py=/usr/bin/python3
rm -rf "$out" && mkdir -p "$out"
"$py" "$src/bench/foreign/make_record.py" --effect "$effect" "${record_args[@]}" --out "$out/record"
if [ "$form" = passage ] || [ "$form" = near-miss ]; then  # the reference case declares the passage
  grep -qE '^"lines.outlet_inertance_Pa_s2_per_m3" = ' "$src/cases/reference.toml" ||
    { echo "the reference case does not declare the outlet passage" >&2; exit 1; }
fi
"$rectify" diagnose --data "$out/record/data.csv" "${diagnose_args[@]}" --out "$out/d" > "$out/diagnose.log" 2>&1 ||
  { cat "$out/diagnose.log"; exit 1; }
"$py" - "$out" "$effect" "$key" "$max_residual" "$min_explained" "$form" "$src" "$expect_cut" "$parameter_tolerance" <<'PY'
import json, math, re, sys
out, effect, key = sys.argv[1:4]
max_residual, min_explained = float(sys.argv[4]), float(sys.argv[5])
form, src = sys.argv[6:8]
expect_cut = sys.argv[8] == "1"
tolerance = float(sys.argv[9])  # 0: the parameter is printed, not checked
s = json.load(open(f"{out}/d/summary.json"))
t = json.load(open(f"{out}/record/truth.json"))
# none refitted from the best candidate's baseline (diagnose.cpp): reported
# wherever a candidate beat none's first fit by the BIC threshold, and kept
# exactly where it fits better; where kept, it is the table's none, or, where
# a left-out parameter was then tried on at none's fit and an effect named
# with it, the none without that parameter
restart = s.get("none_restarted")
table_none = next(c for c in s["candidates"] if c["effect"] == "none")
near = s.get("nearest_miss_with_left_out")
sets = s.get("left_out_judged_with_the_effect_that_sets_it")
none_before_left_out = table_none  # the none that the left-out parameters were tried on at
if near is not None and near.get("named"):  # the table's none is the fit with the passage
    none_before_left_out = near["none_without"]
elif sets is not None and sets["named"] and any(b["on"] for b in sets["at_none"]):  # the same for a hose
    none_before_left_out = sets["none_without"]
if restart is not None:
    print("none restarted from", restart["from_the_baseline_of"], "BIC", restart["bic_from_there"], "against",
          restart["bic_from_the_case"], "kept" if restart["kept"] else "not kept")
    consistent = restart["kept"] == (restart["bic_from_there"] < restart["bic_from_the_case"])
    if restart["kept"]:
        bic = restart["bic_from_there"]
        consistent = consistent and abs(none_before_left_out["bic"] - bic) <= 1e-6 * abs(bic)
    if not consistent:
        print("FAILED: none_restarted is not what the table and its rule say"); sys.exit(1)
if effect == "none":
    # a record without an effect whose none from the case's values stops on
    # another orbit (the outlet valve shut; the record's opens 93 um every
    # cycle) that a leak's search crossed: none from the leak's baseline fits
    # better, nothing is named, and what is left is within the noise
    ok = (s["effect"] == "none" and restart is not None and restart["kept"]
          and s["residual_after"]["overall"] <= max_residual and s["verdict"] == "no missing effect")
    print("named", s["effect"], "verdict", s["verdict"], "residual", s["residual_after"]["overall"])
    print("PASS" if ok else "FAILED"); sys.exit(0 if ok else 1)
v = s["parameters"].get(key)
print("named", s["effect"], key, v, "truth", t["value"], "verdict", s["verdict"], "-", s["verdict_sentence"])
print("start", s["localisation"][0]["start"], "(bench:", t["start"] + ")")
for c in s.get("candidates", []):
    if isinstance(c, dict) and c.get("effect", "").startswith(effect[:12]):
        print("candidate", c.get("effect"), "BIC", c.get("bic"), c.get("parameters"))
print("parameter error %+.1f %%" % (100 * (v / t["value"] - 1)) if v is not None else "no parameter")
ok = s["effect"] == effect and v is not None and (tolerance <= 0 or abs(v / t["value"] - 1) < tolerance)
# a named fit moves along its profile where a side fits better by the
# naming's evidence (diagnose.cpp, BetterSide): in the form line-moved
named = next((r for r in s["rounds"] if r["effect"] == s["effect"]), None) if s["effect"] != "none" else None
moves = named["moved_along_its_profile"] if named else []
print("moved along its profile:", json.dumps(moves))
if form == "line-moved":
    ok = ok and len(moves) >= 1 and all(m["evidence"] < -10 for m in moves)
ok = ok and s["verdict"] in ("explained", "partly explained") and s["explained_fraction"] > min_explained
if s["residual_after"]["overall"] > 2:  # the verdict says what is left
    ok = ok and s["verdict"] == "partly explained"
if t["start"] != "rest":  # a record from mid-operation is not simulated from rest
    ok = ok and s["localisation"][0]["start"] != "rest"
# the named fit's settling window (diagnose.cpp, settle): what its reason
# says, in samples (one cycle where the model's runs never meet)
loc = s["localisation"][0]
if s["effect"] != "none" and loc["start"] != "rest":
    with open(f"{out}/record/data.csv") as fh:
        rows = fh.read().split("\n", 3)[1:3]
    per_cycle = 1.0 / (t["frequency_Hz"] * (float(rows[1].split(",")[0]) - float(rows[0].split(",")[0])))
    m = re.match(r"(\d+|one) cycles?\b", loc.get("settling_reason", ""))
    cycles = None if not m else 1 if m.group(1) == "one" else int(m.group(1))
    print("settling:", loc["settling_samples_left_out"], "samples;", loc.get("settling_reason"))
    ok = ok and cycles is not None and abs(loc["settling_samples_left_out"] - round(cycles * per_cycle)) <= 1
# candidates far from being named are not restarted (diagnose.cpp, fit()):
# never the named one, each closing less than the half of the gap that
# naming needs; some, where expected (expect_cut above)
none = none_before_left_out  # where the table's none has the passage, the notes' was without
if restart is not None:  # the notes were made against none's fit from the case's values, before any refit
    none = {"rms_train": restart["rms_train_from_the_case"]}
gap = lambda r: math.sqrt(max(r * r - 1, 0))
cut = [c for c in s["candidates"] if c.get("search", "").startswith("not restarted")]
for c in cut:
    closed = 1 - gap(c["rms_train"]) / gap(none["rms_train"])
    # the note's numbers: its first searches' share (from the objective, the
    # same mean square), below the 20 % that a restart needs, and the share
    # two more could reach, below the 50 % that naming needs
    m = re.match(r"not restarted: its first searches close (\d+) % of the gap .*, (\d+) % if two more", c["search"])
    said, reach = (int(m.group(1)), int(m.group(2))) if m else (None, None)
    print("not restarted", c["effect"], "closes %.1f %% of the gap; its note says %s %%, %s %% reachable"
          % (100 * closed, said, reach))
    ok = ok and m is not None and c["effect"] != s["effect"] and closed < 0.5
    ok = ok and said < 20 and said <= reach < 50 and abs(said - 100 * max(closed, 0)) <= 1
ok = ok and (len(cut) >= 1 or not expect_cut)
# the line's ringing starts (diagnose.cpp, ringing_start): what its note says
# of each frequency must agree with the rule it states - the pair grids not
# run only where the lines along the baseline do not come below the reach
# it names (x the residual with the line off), a grid refined only where it
# beat that, a start only where the refined point beats it over 6 cycles; in a hose's record the
# named line is found from its ringing (at least one start)
line = next((c for c in s["candidates"] if c["effect"] == "line_inertance"), None)
entries = line.get("ringing", "").split("; ") if line and line.get("ringing") else []
starts = skipped = 0
for e in entries:
    print("line ringing:", e)
    m = re.match(r"(\d+) Hz: the lines along the baseline (\S+) x .*pair grids not run \(below (\S+) x needed\)$", e)
    if m:
        skipped += 1
        ok = ok and float(m.group(2)) >= float(m.group(3))
        continue
    m = re.match(r"(\d+) Hz: its grid (\S+) x the residual with it off over 3 cycles, no further$", e)
    if m:
        ok = ok and float(m.group(2)) >= 1
        continue
    m = re.match(r"(\d+) Hz: its grid (\S+) x .*, refined to (\S+) x over 6 \((a start|not a start)\)$", e)
    if m:
        starts += m.group(4) == "a start"
        six = float(m.group(3))  # (printed to 3 digits: 1 may be either side)
        ok = ok and float(m.group(2)) <= 1 and (abs(six - 1) < 0.005 or (six < 1) == (m.group(4) == "a start"))
        continue
    ok = ok and (e == "no peak in the residual's spectrum where it can ring" or e.endswith("Hz: out of its range"))
print("line ringing: %d frequencies, %d starts, %d pair grids not run" % (len(entries), starts, skipped))
if entries:  # its share of the candidate's runs and time (a part of them)
    print("line ringing: %s of %s runs, %.1f of %.1f s"
          % (line.get("ringing_runs"), line["evaluations"], line.get("ringing_time_s", -1), line["wall_time_s"]))
    ok = ok and 0 <= line.get("ringing_runs", -1) <= line["evaluations"]
    ok = ok and 0 <= line.get("ringing_time_s", -1) <= line["wall_time_s"]
    ok = ok and (line["ringing_runs"] > 0) == (entries != ["no peak in the residual's spectrum where it can ring"])
if form in ("line", "line-short", "line-moved"):
    ok = ok and starts >= 1
print("residual after", s["residual_after"]["overall"], "noise units (at most", max_residual, ")")
ok = ok and s["residual_after"]["overall"] <= max_residual
if form == "passage":  # the outlet passage, tried on at the named fit and kept near the bench's
    sys.path.insert(0, f"{src}/bench/foreign")
    import pump
    n = pump.NOMINAL
    bench = 4 / 3 * n["rho"] * n["outlet_line_l"] / (math.pi * t["baseline"]["line_d"] ** 2 / 4)
    tried = [b for b in s["left_out_tried_at_the_named_fit"] if b["parameter"] == "lines.outlet_inertance_Pa_s2_per_m3"]
    fitted = s["baseline"]["lines.outlet_inertance_Pa_s2_per_m3"]
    print("outlet passage", fitted, "bench", bench, tried)
    ok = ok and len(tried) == 1 and tried[0]["on"] and abs(math.log(fitted / bench)) < math.log(1.5)
if form == "near-miss":  # named only after the passage was tried on at none's fit and at the orifice's
    print("nearest miss", json.dumps(near))
    ok = ok and near is not None and near["effect"] == effect and near["named"]
    # it closed at least the share that earns the try, and failed the rule
    # it says: the gap (less than half closed) or the dominant feature (the
    # gap at least half closed, the feature's sentence given)
    rule, reason = near.get("missed_by"), near.get("reason_without", "")
    print("missed by the %s rule: %s" % (rule, reason))
    ok = ok and 0.2 <= near["gap_closed_without"]
    ok = ok and ((rule == "gap" and near["gap_closed_without"] < 0.5 and "closes only" in reason) or
                 (rule == "feature" and near["gap_closed_without"] >= 0.5 and "dominant feature" in reason))
    ok = ok and ("too little of the dominant feature" if rule == "feature" else "too little of the gap") in s["decision"]
    # the share it closed without, from the fits without (the same rule)
    closed = 1 - gap(near["effect_without"]["rms_train"]) / gap(near["none_without"]["rms_train"]) if ok else -1
    print("closed without the passage %.4f (reported %.4f)" % (closed, near["gap_closed_without"] if ok else -1))
    ok = ok and abs(closed - near["gap_closed_without"]) < 1e-6
    tries = near["at_none"] + near["at_the_effect"] if ok else []
    ok = ok and len(tries) == 2 and all(b["parameter"] == "lines.outlet_inertance_Pa_s2_per_m3" for b in tries)
    ok = ok and any(b["on"] for b in tries) and "nearest miss" in s["decision"]
    same = lambda bs: [(b["parameter"], b["on"], b["fitted"]) for b in bs]
    ok = ok and same(s["left_out_tried_at_the_named_fit"]) == same(near["at_the_effect"])
elif form == "friction-rest":  # named at once, or as the nearest miss once the passage was tried on
    print("nearest miss", json.dumps(near)[:300])
    ok = ok and (near is None or (near["effect"] == effect and near["named"] and "nearest miss" in s["decision"]))
else:  # named at once: the nearest miss is never tried
    ok = ok and near is None
# a hose sets the outlet passage's key, which the case leaves out: it is
# named only where it also beats none with the passage tried on (null for
# the effects that set nothing the case leaves out)
# the friction's shape: held at none's fit, where the model has no friction
# (said so), and never among what is fitted before naming; freed with the
# named friction where the data determine it (the form friction: the sign's
# smoothing or the rise, at least one)
shape = ("load.friction_velocity_scale_m_per_s", "load.static_friction_ratio", "load.stribeck_velocity_m_per_s")
held = {b["parameter"]: b for b in s["baseline_fit"] if b["parameter"] in shape}
print("friction's shape at none's fit:", {k: (b["identifiable"], b["note"][:60]) for k, b in held.items()})
ok = ok and len(held) == 3 and all(not b["identifiable"] and "no piston friction" in b["note"] for b in held.values())
freed = [b["parameter"] for b in s["freed_at_the_named_fit"] if b["parameter"] in shape]
print("friction's shape freed at the named fit:", freed)
# each freed one says how: the effect's shape, or a baseline parameter
ok = ok and all(("shape" in b["freed_as"]) == (b["parameter"] in shape) for b in s["freed_at_the_named_fit"])
if form == "friction":
    ok = ok and len(freed) >= 1
else:
    ok = ok and freed == []
print("judged with what it sets:", json.dumps(sets))
if effect == "line_inertance":
    ok = ok and sets is not None and sets["effect"] == effect and sets["named"] and sets["reason"] == ""
    ok = ok and [b["parameter"] for b in sets["at_none"]] == ["lines.outlet_inertance_Pa_s2_per_m3"]
else:
    ok = ok and sets is None
# the candidates screened on the first training cycles (--compared-cycles):
# each scored on exactly those cycles' samples (every compared signal, the
# record's samples per cycle), the named fit then on every training cycle
if form == "long":
    per_run = s["compared_cycles_per_run"]
    rows = sum(1 for line in open(f"{out}/record/data.csv") if line[:1].isdigit() or line[:1] == "-")
    rows_per_cycle = round(rows / t["cycles"])
    signals = len(s["residual_after"]) - 1  # less "overall"
    fitted = [c for c in s["candidates"] if "compared_samples" in c]
    lo, hi = 12 * rows_per_cycle * signals, (12 * rows_per_cycle + 1) * signals  # one sample more as dt rounds
    print("compared cycles per run", per_run, "; samples per candidate",
          sorted({c["compared_samples"] for c in fitted}), "expected", lo, "to", hi)
    ok = ok and per_run == 12 and len(fitted) == 4
    ok = ok and all(lo <= c["compared_samples"] <= hi for c in fitted)
    log = open(f"{out}/diagnose.log").read()
    ok = ok and "the named effect refitted on every training cycle" in log
else:
    ok = ok and s.get("compared_cycles_per_run", 0) == 0  # a record of at most 32 training cycles: compared whole
sys.exit(0 if ok else 1)
PY
