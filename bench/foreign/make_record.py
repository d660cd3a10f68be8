#!/usr/bin/env python3
"""One record of the independent test bench (bench/foreign/pump.py): a CSV as
`rectify diagnose` reads it, and the truth beside it.

  /usr/bin/python3 bench/foreign/make_record.py --effect valve_leakage --seed 7 --out DIR
      [--scenario no-flow|loaded] [--frequency 100] [--cycles 16] [--value V]
      [--start rest|static|mid|random] [--noise 0.01] [--no-sensor-effects] [--nominal] [--current-pp 8]
      [--without junction|second-mode-draw|seat|passage|lip ...]

Everything not given is drawn from the seed: the baseline parameters inside
pump.RANGES (log-uniform), the effect's parameter inside pump.EFFECTS, the
air's law, the start, the sensors' bandwidths, the coloured noise, the
drift, the outliers and the drive's distortion. DIR/data.csv, DIR/truth.json
(written to temporary files and renamed). The same seed and options make the
same record on every x86-64 machine with AVX2 and FMA (cpu_paths.py).
"""
import argparse, json, math, os, sys, time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import cpu_paths  # noqa: E402  (before NumPy: the same record on every AVX2 machine)
import numpy as np  # noqa: E402
import pump as bench  # noqa: E402


# --without: the bench's differences from rectify's model, each taken
# (almost) away: the inlet junction's oil to 1/100, the second mode at a
# uniform cantilever's 6.267 x the first (drawn as before, then replaced),
# the seat 10x stiffer, the 1 cm outlet passage's inertance to 1/100, the
# seal's lip 1000x faster (its compliance then follows the high side at once)
WITHOUT = {
    "junction": {"junction_volume_factor": 0.01},
    "second-mode-draw": {"mode2_ratio": 6.267},
    "seat": {"seat_stiffness_factor": 10.0},
    "passage": {"outlet_passage_inertance_factor": 0.01},
    "lip": {"seal_time_constant": 1e-7},
}

# each sensor's resolution: its noise never falls below this, however
# little its signal moves (a seated valve, a pressure that has settled)
NOISE_FLOOR = {"current_A": 2e-3, "voltage_V": 4e-3, "outlet_pressure_Pa": 2e3, "chamber_pressure_Pa": 2e3,
               "outlet_valve_m": 5e-8, "strain": 1e-7, "actuator_position_m": 1e-7,
               "actuator_velocity_m_per_s": 1e-4}


def log_uniform(rng, lo, hi):
    return math.exp(rng.uniform(math.log(lo), math.log(hi)))


def first_order_lowpass(x, fs, fc):
    """A sensor's first-order response, discretised exactly for a
    piecewise-constant input (x sampled at fs, bandwidth fc)."""
    a = math.exp(-2 * math.pi * fc / fs)
    y = np.empty_like(x)
    y[0] = x[0]
    for k in range(1, len(x)):
        y[k] = a * y[k - 1] + (1 - a) * x[k]
    return y


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--effect", default="none", choices=["none"] + list(bench.EFFECTS))
    ap.add_argument("--value", type=float, default=None)
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--scenario", default=None, choices=["no-flow", "loaded"],
                    help="default: drawn (records with no effect; loaded 1 in 4) or the effect's. Given for an "
                         "effect-free record, it skips that draw, and every later draw of the seed (the rig) moves")
    ap.add_argument("--frequency", type=float, default=None,
                    help="default: drawn. Given, it skips that draw: the seed then makes another rig (baseline, "
                         "effect, sensors) than without it; for the same rig at another amplitude use --current-pp")
    ap.add_argument("--current-pp", type=float, default=None,
                    help="drive peak-to-peak [A], bias half of it (default: 4 loaded, 20 no-flow); with the "
                         "same seed the same rig (baseline, effect, sensors) at another amplitude")
    ap.add_argument("--cycles", type=int, default=16)
    ap.add_argument("--samples-per-cycle", type=int, default=200)
    ap.add_argument("--start", default="random", choices=["rest", "static", "mid", "random"])
    ap.add_argument("--noise", type=float, default=None, help="white noise sd per column RMS (default: drawn 0.5-1.5 %%)")
    ap.add_argument("--no-sensor-effects", action="store_true", help="white noise only: no sensor dynamics, "
                    "coloured noise, drift, outliers or drive distortion")
    ap.add_argument("--sensor-parts", default="lag,coloured,drift,outliers,distortion",
                    help="which sensor effects to apply (comma list, may be empty; the random draws are the same "
                         "whatever is left out, so one seed gives the same record less those parts; "
                         "--no-sensor-effects overrides it)")
    ap.add_argument("--nominal", action="store_true", help="baseline at the case's values (no random draws)")
    ap.add_argument("--without", action="append", default=[], choices=sorted(WITHOUT),
                    help="one of the bench's differences from rectify's model taken (almost) away, to find which "
                         "sets a residual (docs/diagnosis.md, twenty-fourth stop); every draw stays the seed's. "
                         "Repeatable")
    ap.add_argument("--seal-as-oil", action="store_true",
                    help="with --effect outlet_compliance: the same rig and draws, but the seal's compliance held by "
                         "a longer oil column in the output cylinder (wet_l + C_seal beta / (A_po xi_h)) and no seal: "
                         "the record a no-flow rig makes if its extra compliance is oil (bench/foreign/seal_twin.py)")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    if a.seal_as_oil and a.effect != "outlet_compliance":
        ap.error("--seal-as-oil needs --effect outlet_compliance")

    rng = np.random.default_rng(a.seed)
    truth = {"effect": a.effect, "seed": a.seed, "generator": "bench/foreign (independent of rectify's model)",
             "cpu_paths": cpu_paths.PINNED or "the machine's own"}
    loaded_effects = ("piston_friction", "orifice_flow", "reed_second_mode")
    scenario = a.scenario or ("loaded" if a.effect in loaded_effects else
                              ("loaded" if a.effect == "none" and rng.uniform() < 0.25 else "no-flow"))
    freqs = [75.0, 100.0] if scenario == "loaded" else [50.0, 100.0, 150.0]
    if a.effect == "line_inertance":
        freqs = [100.0, 150.0]
    f = a.frequency or float(rng.choice(freqs))
    pp, bias = (4.0, 2.0) if scenario == "loaded" else (20.0, 10.0)
    if a.current_pp is not None:  # another run of the same rig: every draw below is the seed's as before
        pp, bias = a.current_pp, a.current_pp / 2

    P = dict(bench.NOMINAL)
    baseline = {}
    for k, (lo, hi) in bench.RANGES.items():
        if not a.nominal:
            P[k] = log_uniform(rng, lo, hi)
        baseline[k] = P[k]
    # the reed's second mode: drawn from a stream of its own, so that every
    # draw above and below stays what it was before it was drawn
    if not a.nominal:
        P["mode2_ratio"] = float(np.random.default_rng([a.seed, 2]).uniform(*bench.MODE2_RATIO))
    if "passage" in a.without and a.effect == "line_inertance":
        ap.error("--without passage: the hose of line_inertance replaces the passage")
    for w in a.without:
        P.update(WITHOUT[w])
    baseline["mode2_ratio"] = P["mode2_ratio"]
    if a.without:
        truth["without"] = sorted(a.without)
    value = None
    air_law = "polytropic"
    if a.effect != "none":
        key, lo, hi, log = bench.EFFECTS[a.effect]
        value = a.value if a.value is not None else (log_uniform(rng, lo, hi) if log else rng.uniform(lo, hi))
        truth["parameter"] = key
        truth["value"] = value
        if a.effect == "entrained_air":
            air_law = str(rng.choice(["polytropic", "constant"]))
            truth["air_law"] = air_law
    effect = None if a.effect == "none" else a.effect
    if a.seal_as_oil:  # every draw is made as for the seal; only the rig's physics changes
        extra = value * P["beta"] / (P["A_po"] * P["xi_h"])
        truth["seal_as_oil"] = {"wet_l": P["wet_l"] + extra, "extra_wet_l": extra}
        P["wet_l"] += extra
        effect = None
    start = a.start if a.start != "random" else str(rng.choice(["rest", "static", "mid"]))
    sensors = not a.no_sensor_effects
    parts = {x for x in a.sensor_parts.split(",") if x} if sensors else set()
    unknown = parts - {"lag", "coloured", "drift", "outliers", "distortion"}
    if unknown:
        ap.error(f"--sensor-parts: unknown {sorted(unknown)}")
    noise = a.noise if a.noise is not None else rng.uniform(0.005, 0.015)
    distortion = (rng.uniform(0.005, 0.02) * pp / 2 * rng.choice([-1, 1])) if sensors else 0.0
    if "distortion" not in parts:
        distortion = 0.0
    voltage = a.effect == "coil_dynamics"

    w = 2 * math.pi * f
    T = 1 / f
    # the start: the drive's phase origin and what comes before the record
    runin_cycles = int(rng.integers(20, 61)) if start == "mid" else 0
    phase0 = rng.uniform(0, T) if start == "mid" else (T / 4 if start == "static" else 0.0)

    def sine(t):
        th = w * t
        return bias - pp / 2 * math.cos(th) + distortion * math.sin(2 * th)

    # time axis of the bench: the record is [t_rec, t_rec + cycles T)
    if start == "static":
        t_ramp, t_hold = 0.02, 0.03
        t_rec = t_ramp + t_hold
        def current(t):
            if t < t_ramp:
                return bias * 0.5 * (1 - math.cos(math.pi * t / t_ramp))
            if t < t_rec:
                return bias
            return sine(t - t_rec + phase0)
    else:
        t_rec = runin_cycles * T + phase0
        def current(t):
            return sine(t)
    R_coil = P["R_coil"]
    drive = (lambda t: R_coil * current(t)) if voltage else current

    pump = bench.Pump(P, scenario, effect, value, air_law, drive, voltage)
    n = a.cycles * a.samples_per_cycle
    t_rec_axis = t_rec + np.arange(n) / (a.samples_per_cycle * f)
    y0 = np.zeros(pump.n)
    began = time.time()
    if t_rec > 0:
        pre = bench.integrate(pump, 0.0, t_rec, y0)
        y0 = pre.y[:, -1]
    sol = bench.integrate(pump, t_rec, t_rec_axis[-1], y0, t_eval=t_rec_axis)
    sim_s = time.time() - began
    Y = sol.y
    outs = {k: np.array([pump.outputs(Y[:, j])[k] for j in range(Y.shape[1])]) for k in pump.outputs(Y[:, 0])}
    columns = ["outlet_pressure_Pa", "chamber_pressure_Pa", "outlet_valve_m", "strain"]
    if scenario == "loaded":
        columns += ["actuator_position_m", "actuator_velocity_m_per_s"]
    drive_name = "voltage_V" if voltage else "current_A"
    recorded = {drive_name: np.array([drive(t) for t in t_rec_axis])}
    fs = a.samples_per_cycle * f
    sensor = {}
    for c in columns:
        x = outs[c].copy()
        if sensors:
            if c.endswith("pressure_Pa"):
                fc = log_uniform(rng, 5e3, 2e4)
            elif c == "outlet_valve_m":
                fc = log_uniform(rng, 1e4, 5e4)
            else:
                fc = log_uniform(rng, 2e4, 1e5)
            if fc < 0.45 * fs and "lag" in parts:
                x = first_order_lowpass(x, fs, fc)
            sensor[c] = {"bandwidth_Hz": fc}
        recorded[c] = x
    outliers = []
    for c, x in recorded.items():
        rms = float(np.std(x))
        sd = max(noise * rms, NOISE_FLOOR[c])
        e = rng.normal(0, sd, len(x))
        if sensors:
            rho = rng.uniform(0.7, 0.95)
            ar = np.empty(len(x))
            ar[0] = 0
            g = rng.normal(0, 0.5 * sd * math.sqrt(1 - rho * rho), len(x))
            for k in range(1, len(x)):
                ar[k] = rho * ar[k - 1] + g[k]
            drift = rng.uniform(-1, 1) * 0.003 * rms * np.linspace(0, 1, len(x))
            e = e + (ar if "coloured" in parts else 0.0) + (drift if "drift" in parts else 0.0)
        recorded[c] = x + e
    if sensors and rng.uniform() < 0.5:
        for _ in range(int(rng.integers(1, 4))):
            c = str(rng.choice(columns[:3]))
            k = int(rng.integers(len(t_rec_axis) // 10, len(t_rec_axis)))
            sd = max(noise * float(np.std(recorded[c])), NOISE_FLOOR[c])
            size = 10 ** rng.uniform(1, 3) * sd * rng.choice([-1, 1])
            if "outliers" not in parts:
                continue
            recorded[c][k] += size
            outliers.append({"column": c, "row": k + 1, "time_s": float(t_rec_axis[k] - t_rec), "size": float(size)})

    truth.update({"scenario": scenario, "frequency_Hz": f, "current_pp_A": pp, "current_bias_A": bias,
                  "drive": drive_name, "start": start, "runin_cycles": runin_cycles, "noise": noise,
                  "sensor_effects": sensors, "sensor_parts": sorted(parts), "distortion_A": distortion, "sensors": sensor,
                  "outliers": outliers, "baseline": baseline, "cycles": a.cycles,
                  "simulation_s": sim_s, "second_mode_Hz": pump.f2})
    os.makedirs(a.out, exist_ok=True)
    header = ["time_s", drive_name] + columns
    tmp = os.path.join(a.out, "data.csv.tmp")
    with open(tmp, "w") as fh:
        fh.write(",".join(header) + "\n")
        t0 = t_rec_axis[0]
        for k in range(n):
            row = [f"{t_rec_axis[k] - t0:.10g}"] + [f"{recorded[c][k]:.10g}" for c in header[1:]]
            fh.write(",".join(row) + "\n")
    os.replace(tmp, os.path.join(a.out, "data.csv"))
    tmp = os.path.join(a.out, "truth.json.tmp")
    with open(tmp, "w") as fh:
        json.dump(truth, fh, indent=1)
    os.replace(tmp, os.path.join(a.out, "truth.json"))
    print(f"{a.out}: {a.effect} {value if value is not None else ''} {scenario} {f:g} Hz start {start}, "
          f"{sim_s:.1f} s")


if __name__ == "__main__":
    main()
