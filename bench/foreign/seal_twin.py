#!/usr/bin/env python3
"""How far a seal record of the bench is from its twin whose extra compliance
is oil: what a no-flow record can tell of a soft seal (issue 17).

  /usr/bin/python3 bench/foreign/make_record.py --effect outlet_compliance --seed S --out SEAL
  /usr/bin/python3 bench/foreign/make_record.py --effect outlet_compliance --seed S --seal-as-oil --out OIL
  /usr/bin/python3 bench/foreign/seal_twin.py SEAL OIL [SEAL2 OIL2 ...] [--case cases/reference.toml]

Both records are the same rig with the same draws (sensors, noise, start);
the twin has no seal and an oil column longer by C_seal beta / (A_po xi_h).
For each column the RMS of the records' difference is given in units of the
seal record's white noise (its sd as make_record.py draws it), over every
sample and within the first 10 harmonics of the drive, and the twin's
column against the case's declared upper bound on
`cylinder.wetted_length_m`: a twin within it is a rig the calibrated
baseline holds. Both records carry the same noise, so the difference is
what the physics differs by: the seal's lip (a 0.1 ms lag) and the low
side's oil.
"""
import argparse, csv, json, os, sys, tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from make_record import NOISE_FLOOR  # noqa: E402  (pins NumPy's paths first, as every bench script)
import numpy as np  # noqa: E402

SHORT = {"outlet_pressure_Pa": "outlet p", "chamber_pressure_Pa": "chamber p", "outlet_valve_m": "valve",
         "strain": "strain", "actuator_position_m": "position", "actuator_velocity_m_per_s": "velocity"}


def read(d):
    for f in ("data.csv", "truth.json"):
        if not os.path.isfile(os.path.join(d, f)):
            sys.exit(f"seal_twin.py: {os.path.join(d, f)}: no such file (a record of make_record.py?)")
    path = os.path.join(d, "data.csv")
    with open(path) as fh:
        rows = list(csv.reader(fh))
    head = rows[0] if rows else []
    try:
        data = np.array([[float(v) for v in r] for r in rows[1:]])
    except ValueError as e:
        sys.exit(f"seal_twin.py: {path}: not a record of numbers ({e})")
    if data.ndim != 2 or data.shape[0] < 2 or data.shape[1] != len(head) or "time_s" not in head:
        sys.exit(f"seal_twin.py: {path}: not a record (a header with time_s and rows of its length)")
    path = os.path.join(d, "truth.json")
    try:
        with open(path) as fh:
            truth = json.load(fh)
    except json.JSONDecodeError as e:
        sys.exit(f"seal_twin.py: {path}: not JSON ({e})")
    return {h: data[:, j] for j, h in enumerate(head)}, truth


def band(x, dt, f_max):
    """x with its content above f_max removed (its mean kept)."""
    spec = np.fft.rfft(x)
    spec[np.fft.rfftfreq(len(x), dt) > f_max] = 0
    return np.fft.irfft(spec, len(x))


def compare(seal_dir, oil_dir, length_max):
    a, ta = read(seal_dir)
    b, tb = read(oil_dir)
    if ta.get("effect") != "outlet_compliance" or "seal_as_oil" not in tb or ta["seed"] != tb["seed"]:
        sys.exit(f"seal_twin.py: {seal_dir} and {oil_dir} are not a seal record and its twin of one seed")
    if not np.array_equal(a["time_s"], b["time_s"]):
        sys.exit(f"seal_twin.py: {seal_dir} and {oil_dir} have different time axes (--cycles alike for both?)")
    dt = a["time_s"][1] - a["time_s"][0]
    f = ta["frequency_Hz"]
    out = {"seed": ta["seed"], "seal_m3_per_Pa": ta["value"], "frequency_Hz": f, "start": ta["start"],
           "wet_l": ta["baseline"]["wet_l"], "twin_wet_l": tb["seal_as_oil"]["wet_l"],
           "within_reach": tb["seal_as_oil"]["wet_l"] <= length_max, "columns": {}}
    for c in SHORT:
        if c not in a:
            continue
        sd = max(ta["noise"] * float(np.std(a[c])), NOISE_FLOOR[c])
        d = a[c] - b[c]
        out["columns"][c] = {"every_sample": float(np.sqrt(np.mean(d * d)) / sd),
                             "within_10_harmonics": float(np.sqrt(np.mean(band(d - d.mean(), dt, 10.5 * f) ** 2)
                                                                 + d.mean() ** 2) / sd)}
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dirs", nargs="+", help="pairs: SEAL OIL ...")
    ap.add_argument("--case", default=os.path.join(HERE, "..", "..", "cases", "reference.toml"))
    ap.add_argument("--json", help="also write the pairs' differences here (a list, one entry per pair)")
    a = ap.parse_args()
    if len(a.dirs) % 2:
        ap.error("give the records in pairs: SEAL OIL")
    with open(a.case, "rb") as fh:
        case = tomllib.load(fh)
    try:
        length_max = case["uncertain"]["cylinder.wetted_length_m"][1]
    except KeyError:  # not declared uncertain: the column is the case's
        length_max = case["cylinder"]["wetted_length_m"]
    print(f"| seed | f [Hz] | start | seal [m^3/Pa] | column [m] | twin's column [m] (case's bound {length_max:g}) "
          "| difference, noise units: every sample (within 10 harmonics), per column |")
    print("|---|---|---|---|---|---|---|")
    results = []
    for s, o in zip(a.dirs[::2], a.dirs[1::2]):
        try:
            r = compare(s, o, length_max)
        except KeyError as e:
            sys.exit(f"seal_twin.py: {s} or {o}: truth.json or data.csv lacks {e} (made by make_record.py?)")
        results.append(r)
        cols = "; ".join(f"{SHORT[c]} {v['every_sample']:.3f} ({v['within_10_harmonics']:.3f})"
                         for c, v in r["columns"].items())
        print(f"| {r['seed']} | {r['frequency_Hz']:g} | {r['start']} | {r['seal_m3_per_Pa']:.3g} | {r['wet_l']:.4f} "
              f"| {r['twin_wet_l']:.4f} ({'within' if r['within_reach'] else 'beyond'}) | {cols} |")
    if a.json:
        with open(a.json + ".tmp", "w") as fh:
            json.dump(results, fh, indent=1)
        os.replace(a.json + ".tmp", a.json)


if __name__ == "__main__":
    main()
