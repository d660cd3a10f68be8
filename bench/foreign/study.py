#!/usr/bin/env python3
"""Identification study of `rectify diagnose` on records it did not make
(issue 17): the independent bench (bench/foreign/pump.py) makes each record
with one hidden effect (or none, or one outside the library), the baseline's
uncertain parameters drawn at random, sensor dynamics, coloured noise, drift,
outliers, drive distortion and random starts; `rectify diagnose` names what
it finds as a user would run it (the reference case, all candidates).

  /usr/bin/python3 bench/foreign/study.py --rectify build/bin/rectify --out runs/foreign-study
      [--per-effect 3] [--none 6] [--beyond 3] [--first 0] [--effects E ...] [--scenario loaded]
      [--currents-pp 4 8] [--jobs 2] [--report-only] [--compare OTHER_STUDY]

--first K numbers the records from K (E-K, E-K+1, ...; each its own seed):
a study extended by more records of each kind, beside one already run.

Resumable: DIR/cases.csv gets one row per finished record (a record or a
diagnosis already on disk is not redone). DIR/study.md: the confusion matrix
(rows hidden, columns named), parameter errors, verdicts, residual after the
fit in noise units, time per record, and the issue's targets against what
was measured; with --compare, the records whose outcome moved against
another study's.
"""
import argparse, concurrent.futures, csv, json, math, os, random, subprocess, sys, threading, time, tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import pump as bench  # noqa: E402

# bench effect -> (library effects that count as right, case key of its parameter, conversion bench -> key)
LIBRARY = {
    "entrained_air": (("entrained_air", "entrained_air_constant_modulus"), "free_air_fraction", 1.0),
    "outlet_compliance": (("outlet_compliance",), "seal_compliance_m3_per_Pa", 1.0),
    "valve_leakage": (("valve_leakage", "valve_leakage_turbulent"), "leak_resistance_Pa_s_per_m3", 1.0),
    "valve_leakage_turbulent": (("valve_leakage_turbulent", "valve_leakage"), "leak_area_m2", 1.0),
    "orifice_flow": (("orifice_flow",), "orifice_discharge_coefficient", 1.0),
    "line_inertance": (("line_inertance",), "outlet_inertance_Pa_s2_per_m3", 1.0),
    "coil_dynamics": (("coil_dynamics",), "coil_inductance_H", 1.0),
    "piston_friction": (("piston_friction",), "coulomb_friction_N", 1.0),
    "reed_second_mode": (("reed_second_mode",), "second_mode_frequency_Hz", 1.0),
}
# where the library has two forms of one physics, which one was named
FORMS = {"entrained_air": "polytropic", "entrained_air_constant_modulus": "constant",
         "valve_leakage": "laminar", "valve_leakage_turbulent": "turbulent"}
COLUMNS = ["case", "truth", "scenario", "frequency_Hz", "start", "named", "correct", "verdict", "true_value",
           "fitted_value", "rel_error", "air_law", "named_form", "residual_baseline", "residual_after",
           "explained_fraction", "outliers_true", "outliers_found", "start_chosen", "wall_time_s",
           "reported_sd", "determined", "combined_true", "combined_fitted", "combined_error", "absorbed"]
lock = threading.Lock()


class StudyError(Exception):
    """A file the study reads is missing, not JSON, or lacks a key it needs: the message names the file."""


def read_json(path):
    try:
        with open(path) as fh:
            doc = json.load(fh)
    except json.JSONDecodeError as e:
        raise StudyError(f"{path}: not valid JSON: {e.msg} (line {e.lineno}, column {e.colno})") from None
    except OSError as e:
        raise StudyError(f"{path}: cannot be read: {e.strerror}") from None
    if not isinstance(doc, dict):
        raise StudyError(f"{path}: not a JSON object")
    return doc


def field(doc, path, *keys):
    """doc[keys[0]][keys[1]]... of the JSON file `path`, or a StudyError naming the file and the key."""
    v = doc
    for k in keys:
        try:
            v = v[k]
        except (KeyError, IndexError, TypeError):
            raise StudyError(f"{path}: no {'/'.join(str(k) for k in keys)} (a record's truth.json or a "
                             "diagnosis's summary.json as written by make_record.py and rectify diagnose)") from None
    return v


# a study's row: columns that must be filled, and those that are numbers where filled
ROW_REQUIRED = ("case", "truth", "scenario", "named", "correct", "verdict", "residual_after", "wall_time_s",
                "frequency_Hz")
ROW_NUMBERS = ("frequency_Hz", "residual_baseline", "residual_after", "rel_error", "wall_time_s", "reported_sd",
               "combined_error")
# what --compare reads of another study's rows: these filled, rel_error a column (empty where nothing was named)
COMPARE_REQUIRED = ("case", "named", "verdict", "residual_after")
COMPARE_COLUMNS = COMPARE_REQUIRED + ("rel_error",)


def read_rows(path, required=ROW_REQUIRED):
    """A study's cases.csv (its own, one copied in to finish it, or one to
    --compare with) as rows, each checked: a StudyError names the file, the
    line, the record, the column and the value of the first that is missing
    or not a number (or NaN), or a `correct` that is not 0 or 1."""
    try:
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
    except OSError as e:
        raise StudyError(f"{path}: cannot be read: {e.strerror}") from None
    for line, r in enumerate(rows, start=2):  # the header is line 1
        where = f"{path}: line {line} ({r.get('case') or 'no case'})"
        for k in required:
            if not r.get(k):
                raise StudyError(f"{where}: no {k}")
        for k in ROW_NUMBERS:
            v = r.get(k)
            if v in ("", None):
                continue
            try:
                x = float(v)
            except ValueError:
                raise StudyError(f"{where}: {k} = '{v}' is not a number") from None
            if math.isnan(x):
                raise StudyError(f"{where}: {k} is NaN")
        if r.get("correct") not in (None, "", "0", "1"):
            raise StudyError(f"{where}: correct = '{r['correct']}', not 0 or 1")
    return rows


def plan(args):
    """The records by index first, kind second (E-0 of every kind, then E-1, ...): a study stopped part-way
    has as many records of each kind, give or take one."""
    cases = []
    first = args.first
    for k in range(first, first + max(args.per_effect, args.none, args.beyond)):
        if k < first + args.per_effect:
            cases += [(f"{e}-{k}", e) for e in args.effects]
        if k < first + args.none:
            cases.append((f"none-{k}", "none"))
        if k < first + args.beyond:
            cases += [(f"{e}-{k}", e) for e in bench.BEYOND_LIBRARY]
    return cases


def seed_of(name, base):
    return base + sum((i + 1) * ord(c) for i, c in enumerate(name)) % 100000


def run_case(args, name, effect):
    d = os.path.join(args.out, name)
    rec = os.path.join(d, "record")
    # one record per drive amplitude, all of the same rig (same seed: same
    # baseline, effect, sensors); the first is `record`, the others record-2, ...
    records = [rec] + [os.path.join(d, f"record-{k + 2}") for k in range(len(args.currents_pp) - 1)]
    for k, r in enumerate(records):
        if not os.path.exists(os.path.join(r, "truth.json")):
            cmd = [sys.executable, os.path.join(HERE, "make_record.py"), "--effect", effect,
                   "--seed", str(seed_of(name, args.seed)), "--cycles", str(args.cycles), "--out", r]
            if args.scenario:
                cmd += ["--scenario", args.scenario]
            if args.currents_pp:
                cmd += ["--current-pp", str(args.currents_pp[k])]
            subprocess.run(cmd, check=True, capture_output=True)
    truth_path = os.path.join(rec, "truth.json")
    truth = read_json(truth_path)
    diag = os.path.join(d, "diagnosis")
    began = time.time()
    if not os.path.exists(os.path.join(diag, "summary.json")):
        cmd = [args.rectify, "diagnose", "--data"] + [os.path.join(r, "data.csv") for r in records] + [
               "--out", diag, "--scenario", truth["scenario"], "--threads", str(args.threads)]
        if args.case:
            cmd += ["--case", args.case]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            raise RuntimeError(f"{name}: diagnose failed ({r.returncode}): {r.stderr[-2000:]}")
    wall = time.time() - began
    summary_path = os.path.join(diag, "summary.json")
    s = read_json(summary_path)
    for k in ("effect", "verdict", "residual_after", "localisation"):
        field(s, summary_path, k)
    field(s, summary_path, "residual_after", "overall")
    field(s, summary_path, "localisation", 0)
    for k in ("scenario", "frequency_Hz", "start"):
        field(truth, truth_path, k)
    named = s["effect"]
    right = LIBRARY.get(effect, ((),))[0]
    if effect == "none":
        correct = named == "none"
    elif effect in bench.BEYOND_LIBRARY:
        correct = s["verdict"] in ("beyond the library", "partly explained")
    else:
        correct = named in right
    row = dict(case=name, truth=effect, scenario=truth["scenario"], frequency_Hz=truth["frequency_Hz"],
               start=truth["start"], named=named, correct=int(correct), verdict=s["verdict"],
               true_value=truth.get("value", ""), fitted_value="", rel_error="",
               air_law=truth.get("air_law", ""), named_form="",
               residual_baseline=s.get("residual_baseline_fit", ""), residual_after=s["residual_after"]["overall"],
               explained_fraction=s.get("explained_fraction", ""),
               outliers_true=len(truth.get("outliers", [])),
               outliers_found=sum(len(l.get("outliers", [])) for l in s["localisation"]),
               start_chosen=s["localisation"][0].get("start", ""),
               wall_time_s=s.get("total_wall_time_s", wall),
               # nothing named, but the verdict says the calibrated baseline took this effect up
               absorbed=";".join(a["effect"] for a in s.get("absorbed_by_baseline") or []))
    if effect in LIBRARY and named in right:
        key = LIBRARY[effect][1]
        v = s["parameters"].get(key)  # absent when the other leak form (another key) was named
        if v is not None and truth.get("value"):
            row["fitted_value"] = v
            row["rel_error"] = abs(v / truth["value"] - 1)
        row["named_form"] = FORMS.get(named, "")
        # the parameter's standard error as reported, and whether the record determines it
        for q in s.get("parameter_uncertainty", []):
            if q["parameter"] == key:  # null: a side of its profile fits as well (more than 20 %)
                sd = q["relative_standard_error"]
                row["reported_sd"] = "inf" if sd is None else sd
                row["determined"] = int(q["determined"])
        # the seal and the oil column add up: the bench's high side against the reported sum
        c = s.get("combined")
        if effect == "outlet_compliance" and c and truth.get("value"):
            row["combined_true"] = bench_high_side(truth)
            row["combined_fitted"] = c["value"]
            row["combined_error"] = abs(c["value"] / row["combined_true"] - 1)
    return row


def bench_high_side(truth):
    """The bench's high-side compliance in a seal record: its oil column's and its seal's [m^3/Pa]."""
    b = truth["baseline"]
    return b["A_po"] * bench.NOMINAL["xi_h"] * b["wet_l"] / bench.NOMINAL["beta"] + truth["value"]


def share_within(reach, draws=100000, seed=1):
    """The share of the bench's seal rigs (make_record.py's draws: the seal,
    oil column and piston area log-uniform in their ranges) whose high side
    lies within `reach`."""
    rng = random.Random(seed)
    lu = lambda lo, hi: math.exp(rng.uniform(math.log(lo), math.log(hi)))  # noqa: E731
    _, lo, hi, _ = bench.EFFECTS["outlet_compliance"]
    n = sum(bench_high_side({"value": lu(lo, hi), "baseline": {"A_po": lu(*bench.RANGES["A_po"]),
                                                                 "wet_l": lu(*bench.RANGES["wet_l"])}}) <= reach
            for _ in range(draws))
    return n / draws


def seal_reach(args, rows):
    """The seals against what the case's declared oil column can hold. A
    no-flow record tells the high side's compliance, the column's and the
    seal's together (docs/diagnosis-history.md, "Five records per effect"): where the
    bench's sum lies within what the column reaches at its declared upper
    bound, the calibrated baseline can take the whole seal up as oil. The
    reach is the case's: its [uncertain] upper bound on
    cylinder.wetted_length_m, at the piston area the calibrated baseline
    could reach (the case's where it held it, as in a no-flow record; else
    the area's upper bound), the case's high-side share and bulk modulus.
    Returns the report's lines (none without seal records)."""
    seals = [r for r in rows if r["truth"] == "outlet_compliance"]
    if not seals:
        return []
    case_path = args.case or os.path.join(HERE, "..", "..", "cases", "reference.toml")
    with open(case_path, "rb") as fh:
        case = tomllib.load(fh)
    try:
        length_max = case["uncertain"]["cylinder.wetted_length_m"][1]
    except KeyError:
        length_max = case["cylinder"]["wetted_length_m"]  # not declared uncertain: the column is fixed
    share, beta = case["cylinder"]["high_side_fraction"], case["fluid"]["bulk_modulus_Pa"]
    md = ["", "The seals against what the declared oil column can hold (a no-flow record tells the high side's "
          f"sum; the column reaches {length_max:g} m in {os.path.basename(case_path)}; seal as the baseline "
          "took it up: the verdict's `absorbed_by_baseline`):", "",
          "| case | bench's seal | bench's high side (oil + seal) | the column's reach | within reach | named | "
          "seal as fitted or as taken up | error |", "|---|" + "---|" * 7]
    tally = {True: [0, 0], False: [0, 0]}  # within reach -> [records, reported right]
    absent = []  # rows of a study assembled from another's cases.csv: no record or diagnosis here
    for r in seals:
        d = os.path.join(args.out, r["case"])
        files = [os.path.join(d, "record", "truth.json"), os.path.join(d, "diagnosis", "summary.json")]
        if not all(os.path.isfile(f) for f in files):
            absent.append(r["case"])
            md.append(f"| {r['case']} | not on disk | | | | {r['named']} | | |")
            continue
        truth, s = (read_json(f) for f in files)
        field(truth, files[0], "value")
        for k in ("A_po", "wet_l"):
            field(truth, files[0], "baseline", k)
        high = bench_high_side(truth)
        # the piston area as the calibrated baseline had it: held at the case's, or free to its bound
        area = case["cylinder"]["piston_area_m2"]
        for i, _ in enumerate(s.get("baseline_fit") or []):
            if field(s, files[1], "baseline_fit", i, "parameter") == "cylinder.piston_area_m2" and \
                    field(s, files[1], "baseline_fit", i, "identifiable"):
                area = field(s, files[1], "baseline_fit", i, "bounds", 1)
        reach = area * share * length_max / beta
        within = high <= reach
        seal, how = None, "-"
        if r["named"] == "outlet_compliance" and r["fitted_value"]:
            seal, how = float(r["fitted_value"]), "named"
        else:
            for i, _ in enumerate(s.get("absorbed_by_baseline") or []):
                if field(s, files[1], "absorbed_by_baseline", i, "effect") == "outlet_compliance":
                    seal, how = field(s, files[1], "absorbed_by_baseline", i, "as_the_effect"), "taken up"
        err = f"{100 * (seal / truth['value'] - 1):+.1f} %" if seal else "-"
        # right: named beyond the reach; within it, named or reported as taken up
        right = how == "named" or (within and how == "taken up")
        tally[within][0] += 1
        tally[within][1] += right
        md.append(f"| {r['case']} | {truth['value']:.3g} | {high:.3g} | {reach:.3g} | {'yes' if within else 'no'} | "
                  f"{r['named']} | {f'{seal:.3g} ({how})' if seal else '-'} | {err} |")
    held = case["cylinder"]["piston_area_m2"] * share * length_max / beta
    md += ["", f"Beyond the reach: named {tally[False][1]}/{tally[False][0]}. Within it: named or reported as "
           f"taken up by the baseline {tally[True][1]}/{tally[True][0]}. Of the bench's seal rigs "
           f"{100 * share_within(held):.1f} % lie within the reach at the case's piston area ({held:.3g} m^3/Pa; "
           "100000 draws)."]
    if absent:
        md += ["", f"Not counted: {len(absent)} seal record(s) whose record or diagnosis is not in {args.out} "
               f"({', '.join(absent)}): rows without their files here, as in a study started from another's cases.csv."]
    return md


def targets(rows, threads, jobs):
    """The issue's targets (issue 17) measured on the rows: the report's
    lines. A rate is met at 80 % (naming per effect, "beyond the library")
    or at most 10 % (false positives); the parameter and the residual are
    counted over the records whose hidden effect was named."""
    def rate(k, n, at_least=None, at_most=None):
        if not n:
            return f"0/0", "-"
        met = (at_least is None or k >= at_least * n) and (at_most is None or k <= at_most * n)
        return f"{k}/{n} ({100 * k / n:.0f} %)", "yes" if met else "no"
    md = ["", "Against the issue's targets:", "", "| target | measured | met |", "|---|---|---|"]
    per, met = [], 0
    effects = [e for e in LIBRARY if any(r["truth"] == e for r in rows)]
    for e in effects:
        rs = [r for r in rows if r["truth"] == e]
        k = sum(int(r["correct"]) for r in rs)
        ok = k >= 0.8 * len(rs)
        met += ok
        per.append(f"{e} {k}/{len(rs)}" + ("" if ok else " (below)"))
    if effects:
        md.append(f"| hidden effect named in >= 80 % of its records, per effect | {met} of {len(effects)} effects: "
                  + ", ".join(per) + f" | {'yes' if met == len(effects) else 'no'} |")
    right = [r for r in rows if r["truth"] in LIBRARY and int(r["correct"])]
    errs = [float(r["rel_error"]) for r in right if r["rel_error"] not in ("", None)]
    m, ok = rate(sum(e <= 0.2 for e in errs), len(errs), at_least=1.0)
    md.append(f"| parameter within 20 % where the hidden effect was named | {m} | {ok} |")
    nones = [r for r in rows if r["truth"] == "none"]
    m, ok = rate(sum(r["named"] != "none" for r in nones), len(nones), at_most=0.1)
    md.append(f"| false positives on records with no effect, at most 10 % | {m} | {ok} |")
    outside = [r for r in rows if r["truth"] in bench.BEYOND_LIBRARY]
    m, ok = rate(sum(int(r["correct"]) for r in outside), len(outside), at_least=0.8)
    md.append(f"| outside the library: the verdict says \"beyond the library\", at least 80 % | {m} | {ok} |")
    m, ok = rate(sum(float(r["residual_after"]) <= 2.0 for r in right), len(right), at_least=1.0)
    md.append(f"| residual after <= 2 noise units where the hidden effect was named | {m} | {ok} |")
    times = sorted(float(r["wall_time_s"]) for r in rows)
    if times:
        md.append(f"| time per record (not the benchmark: diagnose --threads {threads}, {jobs} record(s) at once) | "
                  f"median {times[len(times) // 2]:.0f} s, max {times[-1]:.0f} s | see docs/benchmarks.md |")
    return md


def study_csv(path):
    """A study's cases.csv: the file itself, or the one in its folder."""
    return os.path.join(path, "cases.csv") if os.path.isdir(path) else path


def compare(rows, old_path):
    """The records whose outcome differs from another study's (its cases.csv
    or its folder): named effect, verdict, parameter error by more than a
    point, residual after by more than 0.05 noise units. The report's lines."""
    old_path = study_csv(old_path)
    old = {r["case"]: r for r in read_rows(old_path, COMPARE_REQUIRED)}
    err = lambda r: float(r["rel_error"]) if r.get("rel_error") not in ("", None) else None  # noqa: E731
    show = lambda e: "-" if e is None else f"{100 * e:.1f} %"  # noqa: E731
    md = ["", f"Against {old_path} (records in both: what moved):", "",
          "| case | named | verdict | parameter error | residual after |", "|---|---|---|---|---|"]
    both = [r for r in rows if r["case"] in old]
    moved = 0
    for r in both:
        o = old[r["case"]]
        e, eo = err(r), err(o)
        res, reso = float(r["residual_after"]), float(o["residual_after"])
        if (r["named"] == o["named"] and r["verdict"] == o["verdict"] and abs(res - reso) <= 0.05
                and ((e is None) == (eo is None)) and (e is None or abs(e - eo) <= 0.01)):
            continue
        moved += 1
        pair = lambda a, b: a if a == b else f"{b} -> {a}"  # noqa: E731
        md.append(f"| {r['case']} | {pair(r['named'], o['named'])} | {pair(r['verdict'], o['verdict'])} | "
                  f"{pair(show(e), show(eo))} | {reso:.3g} -> {res:.3g} |")
    only = sorted(set(old) - {r["case"] for r in rows})
    md += ["", f"{moved} of {len(both)} records in both moved"
           + (f"; in {old_path} only: {', '.join(only)}" if only else "") + "."]
    return md


def report(args):
    path = os.path.join(args.out, "cases.csv")
    rows = read_rows(path) if os.path.exists(path) else []
    named_cols = sorted({r["named"] for r in rows} | {"none"})
    truths = [e for e in list(LIBRARY) + ["none"] + list(bench.BEYOND_LIBRARY) if any(r["truth"] == e for r in rows)]
    md = ["# Identification study on the independent bench (issue 17)", "",
          f"{len(rows)} records, written by bench/foreign/study.py; rectify diagnose as a user runs it "
          "(reference case with its [uncertain] table, all candidates).", "",
          "| hidden \\ named | " + " | ".join(named_cols) + " | correct | parameter within 20 % | median error | "
          "reported undetermined (its sum within 20 %) | residual after <= 2 noise | verdicts | "
          "none named, the verdict saying the baseline took it up |",
          "|---|" + "---|" * (len(named_cols) + 7)]
    for t in truths:
        rs = [r for r in rows if r["truth"] == t]
        counts = [sum(r["named"] == c for r in rs) for c in named_cols]
        correct = sum(int(r["correct"]) for r in rs)
        errs = [float(r["rel_error"]) for r in rs if r["rel_error"] not in ("", None)]
        within = sum(e <= 0.2 for e in errs)
        med = f"{100 * sorted(errs)[len(errs) // 2]:.1f} %" if errs else "-"
        undetermined = [r for r in rs if r.get("determined") == "0"]
        sums = sum(float(r["combined_error"]) <= 0.2 for r in undetermined if r.get("combined_error"))
        und = f"{len(undetermined)} ({sums})" if undetermined else "0"
        ok_res = [r for r in rs if int(r["correct"]) and t in LIBRARY]
        res2 = sum(float(r["residual_after"]) <= 2.0 for r in ok_res)
        verdicts = {}
        for r in rs:
            verdicts[r["verdict"]] = verdicts.get(r["verdict"], 0) + 1
        md.append(f"| {t} | " + " | ".join(str(c) for c in counts) +
                  f" | {correct}/{len(rs)} | {within}/{len(errs) if errs else 0} | {med} | {und} | "
                  f"{(str(res2) + '/' + str(len(ok_res))) if t in LIBRARY else '-'} | " +
                  ", ".join(f"{k}: {v}" for k, v in sorted(verdicts.items())) + " | " +
                  str(sum(t in (r.get("absorbed") or "").split(";") for r in rs if r["named"] == "none")) + " |")
    times = sorted(float(r["wall_time_s"]) for r in rows)
    if times:
        md += ["", f"Time per record (diagnose --threads {args.threads}): median {times[len(times) // 2]:.0f} s, "
               f"max {times[-1]:.0f} s."]
    md += ["", "Per record (error: of the fitted parameter; +-: its standard error as reported, * where the "
           "report says the record does not determine it):", "",
           "| case | hidden | scenario | f [Hz] | start (bench / chosen) | named | verdict | "
           "true | fitted | error (+-) | residual baseline -> after | outliers (bench / found) |", "|---|" + "---|" * 11]
    for r in rows:
        err = f"{100 * float(r['rel_error']):.1f} %" if r["rel_error"] not in ("", None) else "-"
        star = "*" if r.get("determined") == "0" else ""
        if r.get("reported_sd") not in ("", None) and math.isfinite(float(r["reported_sd"])):
            err += f" (+-{100 * float(r['reported_sd']):.2g} %{star})"
        elif star:  # more than 20 %: a side of its profile fits as well
            err += " (+- > 20 %*)"
        md.append(f"| {r['case']} | {r['truth']} | {r['scenario']} | {float(r['frequency_Hz']):g} | "
                  f"{r['start']} / {r['start_chosen']} | {r['named']}"
                  f"{' (baseline took up ' + r['absorbed'] + ')' if r.get('absorbed') else ''} | {r['verdict']} | "
                  f"{r['true_value'][:9]} | "
                  f"{str(r['fitted_value'])[:9]} | {err} | {float(r['residual_baseline'] or 0):.3g} -> "
                  f"{float(r['residual_after']):.3g} | {r['outliers_true']} / {r['outliers_found']} |")
    goals = targets(rows, args.threads, args.jobs)
    md += goals + seal_reach(args, rows)
    if args.compare:
        md += compare(rows, args.compare)
    tmp = os.path.join(args.out, "study.md.tmp")
    open(tmp, "w").write("\n".join(md) + "\n")
    os.replace(tmp, os.path.join(args.out, "study.md"))
    print("\n".join(md[:len(truths) + 8] + goals))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rectify", default="build/bin/rectify")
    ap.add_argument("--case", default=None)
    ap.add_argument("--out", required=True)
    ap.add_argument("--per-effect", type=int, default=3)
    ap.add_argument("--none", type=int, default=6)
    ap.add_argument("--beyond", type=int, default=3)
    ap.add_argument("--first", type=int, default=0, help="number the records from this index (extend a study)")
    ap.add_argument("--effects", nargs="*", default=list(LIBRARY))
    ap.add_argument("--scenario", choices=["no-flow", "loaded"], default=None,
                    help="every record in this scenario (default: the effect's own; none: loaded in 1 of 4)")
    ap.add_argument("--currents-pp", type=float, nargs="*", default=[],
                    help="one record per drive amplitude [A p-p] for each case, diagnosed together "
                         "(default: one record at the scenario's amplitude)")
    ap.add_argument("--cycles", type=int, default=16)
    ap.add_argument("--seed", type=int, default=1700)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--threads", type=int, default=1, help="diagnose --threads per record")
    ap.add_argument("--report-only", action="store_true")
    ap.add_argument("--compare", default=None, help="another study's folder or cases.csv: the report lists what moved")
    args = ap.parse_args()
    if args.compare:  # checked now, not after hours of records
        other = study_csv(args.compare)
        if not os.path.isfile(other):
            sys.exit(f"study.py: --compare {args.compare}: no study there (no file {other})")
        with open(other) as fh:
            missing = set(COMPARE_COLUMNS) - set(csv.DictReader(fh).fieldnames or [])
        if missing:
            sys.exit(f"study.py: --compare {other}: not a study's cases.csv (no column {', '.join(sorted(missing))})")
        try:
            read_rows(other, COMPARE_REQUIRED)
        except StudyError as e:
            sys.exit(f"study.py: --compare {e}")
    os.makedirs(args.out, exist_ok=True)
    if args.report_only:
        try:
            report(args)
        except StudyError as e:  # nothing written: study.md is replaced only once whole
            sys.exit(f"study.py: {e}")
        return
    path = os.path.join(args.out, "cases.csv")
    if os.path.exists(path):  # written by an older study.py: its rows under today's columns
        with open(path) as fh:
            reader = csv.DictReader(fh)
            old, header = list(reader), reader.fieldnames
        if header != COLUMNS:
            with open(path + ".tmp", "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=COLUMNS)
                w.writeheader()
                for r in old:
                    w.writerow({k: r.get(k, "") for k in COLUMNS})
            os.replace(path + ".tmp", path)
    done = {r["case"] for r in csv.DictReader(open(path))} if os.path.exists(path) else set()
    todo = [c for c in plan(args) if c[0] not in done]
    print(f"{len(done)} records done, {len(todo)} to go", flush=True)

    def work(c):
        try:
            row = run_case(args, *c)
        except Exception as e:  # a failed record is reported and the study goes on
            print(f"{c[0]}: FAILED {e}", flush=True)
            return
        with lock:
            new = not os.path.exists(path)
            with open(path, "a", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=COLUMNS)
                if new:
                    w.writeheader()
                w.writerow(row)
            print(f"{row['case']}: named {row['named']} ({row['verdict']}), residual {float(row['residual_after']):.3g}, "
                  f"{float(row['wall_time_s']):.0f} s", flush=True)

    with concurrent.futures.ThreadPoolExecutor(args.jobs) as ex:
        list(ex.map(work, todo))
    try:
        report(args)
    except StudyError as e:
        sys.exit(f"study.py: {e}")


if __name__ == "__main__":
    main()
