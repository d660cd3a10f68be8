#!/usr/bin/env python3
"""Run rectify's model on the rig of a bench record and compare the two
(docs/diagnosis-history.md, "What decides a loaded record").

  /usr/bin/python3 bench/foreign/compare_model.py --record DIR --rectify build/bin/rectify --out OUT
      [--case cases/reference.toml] [--harmonics 4 10] [--rtol 1e-7]

DIR is a record of make_record.py with its truth.json. For a like-for-like
comparison make it with --no-sensor-effects, a tiny --noise, --start rest
and the bench's differences taken away (--without junction, passage, seat,
second-mode-draw). The case gets the record's drawn baseline (the lines'
bore, the oil column, the cylinder's area, the gas volume, the force gain as
the piezomagnetic coefficient, the second mode as its ratio to the first,
the 1 cm outlet passage unless the record was made --without it) and its
hidden effect, then `rectify simulate` runs it from rest for as many
cycles as the record has. Both are phase-averaged over the second half of
the cycles (--first-cycle); per signal the script prints the RMS difference as a share of
the bench's swing (the whole band, and within each --harmonics), and the
means. OUT/case.toml, OUT/model/ (the simulation) and OUT/comparison.json.
"""
import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import pump as bench  # noqa: E402

# the hidden effect's parameter -> the case's (table, key): value (the bench's own form of it)
EFFECT_KEYS = {
    "orifice_flow": lambda v: {("valves", "orifice_discharge_coefficient"): v},
    "valve_leakage": lambda v: {("valves", "leak_resistance_Pa_s_per_m3"): v},
    "valve_leakage_turbulent": lambda v: {("valves", "leak_area_m2"): v},
    "reed_second_mode": lambda v: {("reed", "second_mode_frequency_Hz"): v},
    # the bench's friction: F_c (1 + 0.3 exp(-(v / 2 mm/s)^2)) tanh(v / 0.5 mm/s)
    "piston_friction": lambda v: {("load", "coulomb_friction_N"): v, ("load", "static_friction_ratio"): 1.3,
                                  ("load", "stribeck_velocity_m_per_s"): 2e-3,
                                  ("load", "friction_velocity_scale_m_per_s"): 0.5e-3},
}
# model column for each of the record's
COLUMNS = {
    "actuator_velocity_m_per_s": "actuator_velocity_m_per_s",
    "chamber_pressure_Pa": "chamber_pressure_Pa",
    "outlet_pressure_Pa": "outlet_pressure_Pa",
    "outlet_valve_m": "outlet_reed_m",
}


def fail(msg):
    sys.exit(f"compare_model.py: {msg}")


def set_key(text, section, key, value, path):
    """Sets `key = value` inside [section] of a TOML text (the case's own line)."""
    m = re.search(r"^\[%s\]\s*$" % re.escape(section), text, re.M)
    if not m:
        fail(f"{path}: no [{section}] table")
    end = re.search(r"^\[", text[m.end():], re.M)
    body_end = m.end() + (end.start() if end else len(text) - m.end())
    body = text[m.end():body_end]
    pat = re.compile(r"^(%s\s*=\s*)([^\s#]+)" % re.escape(key), re.M)
    if not pat.search(body):
        fail(f"{path}: [{section}] has no key {key}")
    body = pat.sub(lambda k: k.group(1) + repr(float(value)), body, count=1)
    return text[:m.end()] + body + text[body_end:]


def rig_case(case_text, truth, case_path):
    b, P = truth["baseline"], bench.NOMINAL
    f1 = math.sqrt(P["k_r"] / P["m_r"]) / (2 * math.pi)
    t = case_text
    t = set_key(t, "lines", "diameter_m", b["line_d"], case_path)
    t = set_key(t, "cylinder", "wetted_length_m", b["wet_l"], case_path)
    t = set_key(t, "cylinder", "piston_area_m2", b["A_po"], case_path)
    t = set_key(t, "accumulator", "gas_volume_m3", b["V_gas"], case_path)
    t = set_key(t, "transducer", "piezomagnetic_coefficient_m_per_A", P["q_pm"] * b["force_gain"], case_path)
    t = set_key(t, "reed", "second_mode_frequency_Hz", b["mode2_ratio"] * f1, case_path)
    if "passage" not in truth.get("without", []):
        # the bench's 1 cm outlet passage, as the model writes one: its
        # inertance 4/3 rho l / A, with its resistance and oil, one section
        area = math.pi * b["line_d"] ** 2 / 4
        t = set_key(t, "lines", "outlet_inertance_Pa_s2_per_m3", 4.0 / 3.0 * P["rho"] * P["outlet_line_l"] / area,
                    case_path)
    effect = truth["effect"]
    if effect != "none":
        if effect not in EFFECT_KEYS:
            fail(f"effect {effect}: not compared here (only none, {', '.join(sorted(EFFECT_KEYS))})")
        for (section, key), value in EFFECT_KEYS[effect](truth["value"]).items():
            t = set_key(t, section, key, value, case_path)
    return t


def phase_average(t, y, f, first, cycles, n=200):
    tt = np.arange(first * n, cycles * n) / (n * f)
    return np.interp(tt, t, y).reshape(cycles - first, n).mean(axis=0)


def band(y, k):
    c = np.fft.rfft(y)
    c[k + 1:] = 0
    return np.fft.irfft(c, len(y))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--record", required=True)
    ap.add_argument("--rectify", default="build/bin/rectify")
    ap.add_argument("--case", default=os.path.join(HERE, "..", "..", "cases", "reference.toml"))
    ap.add_argument("--out", required=True)
    ap.add_argument("--harmonics", type=int, nargs="*", default=[4, 10])
    ap.add_argument("--rtol", type=float, default=1e-7)
    ap.add_argument("--first-cycle", type=int, default=None, help="first cycle averaged (default: half the record's)")
    a = ap.parse_args()

    truth_path = os.path.join(a.record, "truth.json")
    data_path = os.path.join(a.record, "data.csv")
    for p in (truth_path, data_path, a.case):
        if not os.path.isfile(p):
            fail(f"{p}: no such file")
    truth = json.load(open(truth_path))
    if truth.get("start") != "rest":
        print(f"note: the record starts at '{truth.get('start')}', the model from rest: "
              "compare its later cycles only", file=sys.stderr)
    if truth.get("sensor_effects"):
        print("note: the record has sensor effects (lags, coloured noise, drift): they are in the difference",
              file=sys.stderr)
    if truth.get("drive") != "current_A":
        fail(f"{truth_path}: drive '{truth.get('drive')}': only current-driven records are compared")

    if any(k < 1 for k in a.harmonics):
        fail(f"--harmonics {a.harmonics}: each must be at least 1")
    case = rig_case(open(a.case).read(), truth, a.case)
    # the model's pressures are gauge about the case's bias, the record's absolute
    bias = tomllib.loads(case)["fluid"]["bias_pressure_Pa"]
    os.makedirs(a.out, exist_ok=True)
    # the case's tables beside it (the resistance map is read relative to the case)
    for name in os.listdir(os.path.dirname(os.path.abspath(a.case))):
        if name.endswith(".csv"):
            shutil.copy(os.path.join(os.path.dirname(os.path.abspath(a.case)), name), a.out)
    case_path = os.path.join(a.out, "case.toml")
    with tempfile.NamedTemporaryFile("w", dir=a.out, delete=False, suffix=".tmp") as f:
        f.write(case)
    os.replace(f.name, case_path)

    data = np.genfromtxt(data_path, delimiter=",", names=True)
    freq = truth["frequency_Hz"]
    cycles = int(round((data["time_s"][-1] - data["time_s"][0]) * freq))
    if cycles < 4:
        fail(f"{data_path}: {cycles} cycles; at least 4 are needed")
    model_dir = os.path.join(a.out, "model")
    cmd = [a.rectify, "simulate", "--case", case_path, "--scenario", truth["scenario"],
           "--frequency", repr(freq), "--cycles", str(cycles), "--current-pp", repr(truth["current_pp_A"]),
           "--current-bias", repr(truth["current_bias_A"]), "--rtol", repr(a.rtol), "--out", model_dir]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        fail(f"rectify simulate failed:\n{run.stdout}{run.stderr}")
    model = np.genfromtxt(os.path.join(model_dir, "timeseries.csv"), delimiter=",", names=True)

    first = cycles // 2 if a.first_cycle is None else a.first_cycle
    if not 0 <= first < cycles:
        fail(f"--first-cycle {first}: outside the record's {cycles} cycles")
    result = {"record": os.path.abspath(a.record), "cycles_averaged": [first, cycles], "signals": {}}
    print(f"{truth['effect']}, {truth['scenario']}, {freq:g} Hz, phase-averaged over cycles {first}-{cycles - 1}")
    print(f"{'signal':28s} {'band':>8s} {'bench swing':>12s} {'model swing':>12s} {'bench mean':>12s} "
          f"{'model mean':>12s} {'RMS diff / swing':>16s}")
    for col, mcol in COLUMNS.items():
        if col not in data.dtype.names:
            continue
        yb = phase_average(data["time_s"], data[col], freq, first, cycles)
        ym = phase_average(model["time_s"], model[mcol], freq, first, cycles)
        if col.endswith("_Pa"):
            ym = ym + bias
        rows = {}
        for k in [0] + list(a.harmonics):
            b, m = (yb, ym) if k == 0 else (band(yb, k), band(ym, k))
            swing = float(b.max() - b.min())
            rows["whole" if k == 0 else f"{k} harmonics"] = {
                "bench_swing": swing, "model_swing": float(m.max() - m.min()),
                "bench_mean": float(b.mean()), "model_mean": float(m.mean()),
                "rms_difference_over_swing": float(np.sqrt(np.mean((m - b) ** 2)) / swing) if swing > 0 else None}
        result["signals"][col] = rows
        for name, r in rows.items():
            d = r["rms_difference_over_swing"]
            print(f"{col:28s} {name:>8s} {r['bench_swing']:12.4g} {r['model_swing']:12.4g} {r['bench_mean']:12.6g} "
                  f"{r['model_mean']:12.6g} {('%.2f %%' % (100 * d)) if d is not None else '-':>16s}")
    out = os.path.join(a.out, "comparison.json")
    with tempfile.NamedTemporaryFile("w", dir=a.out, delete=False, suffix=".tmp") as f:
        json.dump(result, f, indent=1)
    os.replace(f.name, out)


if __name__ == "__main__":
    main()
