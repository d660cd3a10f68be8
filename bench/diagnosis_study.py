#!/usr/bin/env python3
"""Identification study of `rectify diagnose` (issue 4): for every effect of
the library, synthetic runs with the effect hidden at random parameter
values, noise of 1-2 % and several pumping frequencies; plus runs with no
effect. Writes DIR/cases.csv (one row per case, appended as cases finish, so
an interrupted study resumes where it stopped) and DIR/study.md (confusion
matrix, parameter errors, residual shrink).

  python3 bench/diagnosis_study.py --rectify build/bin/rectify --out runs/study [--per-effect 10] [--none 20]

Frequencies: 50, 100 and 150 Hz no-flow (20 A p-p), 75 and 100 Hz loaded
(4 A p-p; friction, orifice flow and the second reed mode, which need flow): operating points where the thesis model's response is periodic.
At 200 Hz and above the no-flow response is period-3 and, loaded at 20 A,
non-periodic (valve flutter): there a trajectory depends on the drive's
measurement noise itself, and the residual floor rises (docs/diagnosis.md).

Parameters are drawn log-uniformly (or uniformly) inside each effect's study
range below: the part of its bounds where the effect moves the signals by
more than a few times the noise floor (docs/diagnosis.md gives the detection
limits).
"""
import argparse, concurrent.futures, csv, json, math, os, random, subprocess, sys, threading, time

STUDY = {
    # effect: (key, low, high, log, scenario, frequencies, extra synth args)
    "entrained_air": ("free_air_fraction", 5e-3, 1.5e-2, True, "no-flow", [50, 100, 150], []),
    "outlet_compliance": ("seal_compliance_m3_per_Pa", 1e-12, 1e-10, True, "no-flow", [50, 100, 150], []),
    "valve_leakage": ("leak_resistance_Pa_s_per_m3", 2e10, 5e12, True, "no-flow", [50, 100, 150], []),
    # valve effects show in the flow: loaded runs (a no-flow run's valve passes little)
    "orifice_flow": ("orifice_discharge_coefficient", 0.35, 0.5, False, "loaded", [75, 100],
                     ["--current-pp", "4", "--current-bias", "2"]),
    # the line rings after each closing of the outlet valve (lightly damped,
    # L with the node's compliance); at 150 Hz that ringing makes the no-flow
    # response depend on the drive's noise (held-out residual above none's)
    "line_inertance": ("outlet_inertance_Pa_s2_per_m3", 4e7, 3e8, True, "no-flow", [50, 100], []),
    "coil_dynamics": ("coil_inductance_H", 5e-4, 5e-3, True, "no-flow", [50, 100, 150], []),
    "piston_friction": ("coulomb_friction_N", 4.0, 60.0, True, "loaded", [75, 100],
                        ["--current-pp", "4", "--current-bias", "2"]),
    "reed_second_mode": ("second_mode_frequency_Hz", 2000.0, 3000.0, True, "loaded", [75, 100],
                         ["--current-pp", "4", "--current-bias", "2"]),
}
NONE_FREQUENCIES = [50, 100, 150]
COLUMNS = ["case", "truth", "named", "correct", "key", "true_value", "fitted_value", "rel_error",
           "residual_before", "residual_after", "shrink", "frequency_Hz", "noise", "scenario",
           "confidence", "wall_time_s"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rectify", default="build/bin/rectify")
    ap.add_argument("--case", default=None)
    ap.add_argument("--out", required=True)
    ap.add_argument("--per-effect", type=int, default=10)
    ap.add_argument("--per-loaded-effect", type=int, default=None,
                    help="cases per effect studied in loaded runs (default: --per-effect; loaded runs cost ~4x)")
    ap.add_argument("--none", type=int, default=20)
    ap.add_argument("--cycles", type=int, default=16)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--effects", nargs="*", default=list(STUDY))
    ap.add_argument("--jobs", type=int, default=2, help="cases at once (each diagnose then uses one thread)")
    ap.add_argument("--report-only", action="store_true", help="only (re)write study.md from cases.csv")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rng = random.Random(a.seed)
    cases = []
    for effect in a.effects:
        key, lo, hi, log, scenario, freqs, extra = STUDY[effect]
        count = a.per_loaded_effect if scenario == "loaded" and a.per_loaded_effect else a.per_effect
        for i in range(count):
            u = rng.random()
            value = lo * (hi / lo) ** u if log else lo + u * (hi - lo)
            cases.append((f"{effect}-{i:02d}", effect, key, value, scenario, freqs[i % len(freqs)],
                          round(rng.uniform(0.01, 0.02), 4), extra))
    for i in range(a.none):
        loaded = i % 4 == 0
        cases.append((f"none-{i:02d}", "none", "", 0.0, "loaded" if loaded else "no-flow",
                       [75, 100][i // 4 % 2] if loaded else NONE_FREQUENCIES[i % 3], round(rng.uniform(0.01, 0.02), 4),
                       [] if i % 4 else ["--current-pp", "4", "--current-bias", "2"]))

    table = os.path.join(a.out, "cases.csv")
    if a.report_only:
        report(a.out, table, a.rectify)
        return
    done = set()
    if os.path.exists(table):
        with open(table) as f:
            done = {row["case"] for row in csv.DictReader(f)}
    else:
        with open(table, "w") as f:
            f.write(",".join(COLUMNS) + "\n")
    case_args = ["--case", a.case] if a.case else []
    start = time.time()
    lock = threading.Lock()

    def one(n, case):
        name, truth, key, value, scenario, freq, noise, extra = case
        d = os.path.join(a.out, name)
        synth = [a.rectify, "synth", *case_args, "--effect", truth, "--noise", str(noise),
                 "--seed", str(1000 + n), "--scenario", scenario, "--frequency", str(freq),
                 "--cycles", str(a.cycles), "--out", d, *extra]
        if truth != "none":
            synth += ["--param", f"{key}={value!r}"]
        subprocess.run(synth, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t0 = time.time()
        # the records' reed is the case's (synth: one mode unless the effect
        # is a second one): the baseline keeps it (the sanity level)
        subprocess.run([a.rectify, "diagnose", *case_args, "--scenario", scenario, "--reed-second-mode", "case",
                        "--threads",
                        str(max(1, 2 // a.jobs)), "--data", os.path.join(d, "data.csv"), "--out",
                        os.path.join(d, "diagnosis")],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wall = time.time() - t0
        s = json.load(open(os.path.join(d, "diagnosis", "summary.json")))
        fitted = s["parameters"].get(key, float("nan")) if key else float("nan")
        rel = abs(fitted / value - 1) if key and s["effect"] == truth else float("nan")
        before, after = s["residual_before"]["overall"], s["residual_after"]["overall"]
        row = [name, truth, s["effect"], int(s["effect"] == truth), key, value, fitted, rel, before,
               after, 1 - after / before, freq, noise, scenario, s["confidence"], round(wall, 1)]
        with lock:
            with open(table, "a") as f:
                f.write(",".join(str(x) for x in row) + "\n")
            print(f"[{n + 1}/{len(cases)}] {name}: named {s['effect']}"
                  + (f", {key} {fitted:.4g} vs {value:.4g} ({100 * rel:.1f} %)" if key and s['effect'] == truth else "")
                  + f", residual {before:.3g} -> {after:.3g}, {wall:.0f} s ({time.time() - start:.0f} s in all)",
                  flush=True)

    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        futures = [pool.submit(one, n, case) for n, case in enumerate(cases) if case[0] not in done]
        for f in futures:
            f.result()
    report(a.out, table, a.rectify)


def gaps(out, rectify, rows):
    """Gap of the model to the noise-free truth, before and after, in noise
    units: the record simulated again without noise (synth --noise 0 from
    answer.json) against the overlay's model columns. The residual against
    the data cannot fall below the noise (about 1 unit), so for an effect a
    few noise units strong its shrink is capped well below 80 %; the gap to
    the truth is not. Cached in DIR/<case>/gap.json."""
    result = {}
    for r in rows:
        d = os.path.join(out, r["case"])
        cache = os.path.join(d, "gap.json")
        if r["truth"] == "none" or r["correct"] != "1":
            continue
        if not os.path.exists(cache):
            a = json.load(open(os.path.join(d, "answer.json")))
            clean_dir = os.path.join(d, "clean")
            cmd = [rectify, "synth", "--case", a["case"], "--effect", a["effect"], "--noise", "0", "--drive-noise", "0",
                   "--scenario", a["scenario"], "--frequency", repr(a["frequency_Hz"]), "--cycles", str(a["cycles"]),
                   "--samples-per-cycle", str(a["samples_per_cycle"]), "--current-pp", repr(a["current_pp_A"]),
                   "--current-bias", repr(a["current_bias_A"]),
                   "--drive", "voltage" if a["drive"] == "voltage_V" else "current", "--out", clean_dir]
            for k, v in a["parameters"].items():
                cmd += ["--param", f"{k}={v!r}"]
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            clean = list(csv.DictReader(open(os.path.join(clean_dir, "data.csv"))))
            overlay = list(csv.DictReader(open(os.path.join(d, "diagnosis", "overlay-1.csv"))))
            if len(clean) != len(overlay) or any(abs(float(c["time_s"]) - float(o["time_s"])) > 1e-9
                                                 for c, o in zip(clean, overlay)):
                raise SystemExit(f"{d}: clean record and overlay do not share their times")
            s = json.load(open(os.path.join(d, "diagnosis", "summary.json")))
            g = {"before": 0.0, "after": 0.0}
            signals = [k for k in s["residual_before"] if k != "overall"]
            for sig in signals:
                n = len(overlay)
                rms = lambda col, ref: math.sqrt(sum((float(o[col]) - ref(i)) ** 2 for i, o in enumerate(overlay)) / n)
                scale = rms("before_" + sig, lambda i: float(overlay[i]["data_" + sig])) / s["residual_before"][sig]
                for when in ("before", "after"):
                    g[when] += (rms(f"{when}_{sig}", lambda i: float(clean[i][sig])) / scale) ** 2 / len(signals)
            g = {k: math.sqrt(v) for k, v in g.items()}
            with open(cache + ".tmp", "w") as f:
                json.dump(g, f)
            os.replace(cache + ".tmp", cache)
        result[r["case"]] = json.load(open(cache))
    return result


def report(out, table, rectify=None):
    rows = list(csv.DictReader(open(table)))
    gap = gaps(out, rectify, rows) if rectify else {}
    names = list(STUDY) + ["none"]
    seen = [n for n in names if any(r["truth"] == n for r in rows)]
    named = sorted({r["named"] for r in rows} | set(seen), key=lambda x: names.index(x) if x in names else 99)
    md = ["| hidden \\ named | " + " | ".join(named) + " | correct | parameter error (median / max) | within 10 % | shrink (min) | shrink >= 80 % |"
          + (" gap to truth shrink (min) | gap shrink >= 80 % |" if gap else ""),
          "|---|" + "---|" * (len(named) + 5 + (2 if gap else 0))]
    for t in seen:
        rs = [r for r in rows if r["truth"] == t]
        counts = [sum(1 for r in rs if r["named"] == n) for n in named]
        ok = sum(int(r["correct"]) for r in rs)
        errs = sorted(float(r["rel_error"]) for r in rs if r["correct"] == "1" and r["rel_error"] != "nan")
        shrinks = [float(r["shrink"]) for r in rs if r["correct"] == "1"]
        perr = f"{100 * errs[len(errs) // 2]:.1f} % / {100 * errs[-1]:.1f} %" if errs else "-"
        shr = f"{100 * min(shrinks):.0f} %" if shrinks and t != "none" else "-"
        within = f"{sum(1 for e in errs if e <= 0.1)}/{len(rs)}" if t != "none" else "-"
        big = f"{sum(1 for x in shrinks if x >= 0.8)}/{len(rs)}" if t != "none" else "-"
        line = f"| {t} | " + " | ".join(str(c) for c in counts) + f" | {ok}/{len(rs)} ({100 * ok / len(rs):.0f} %) | {perr} | {within} | {shr} | {big} |"
        if gap:
            gs = [1 - gap[r["case"]]["after"] / gap[r["case"]]["before"] for r in rs if r["case"] in gap]
            line += (f" {100 * min(gs):.0f} % | {sum(1 for x in gs if x >= 0.8)}/{len(rs)} |" if gs and t != "none"
                     else " - | - |")
        md.append(line)
    with open(os.path.join(out, "study.md"), "w") as f:
        f.write("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
