#!/usr/bin/env python3
"""An independent test bench for `rectify diagnose` (issue 17): measured-like
records of the Terfenol-D pump made WITHOUT rectify's system model.

Written separately from system/ (Python, SciPy's LSODA instead of CVODE), from
the physics of the thesis (ch. 3, Table A.1) with its own choices where the
diagnosis model makes others:

  - each reed has TWO bending modes (tip-normalised, equal modal masses, the
    second at 5.6-7.0 x the first, drawn; a uniform cantilever's is 6.27)
    instead of one;
  - the seat is a stiff penalty contact (spring + damper on the tip's
    penetration) instead of an event that stops the reed exactly;
  - R(x) of the thesis interpolated log-linearly in the opening (not a
    monotone cubic), closed-valve resistance blended over the first 0.2 um;
  - the outlet line is distributed (sections with inertance, resistance
    and its oil's compliance, each section's oil at its upstream end: 4 for
    the 1 cm manifold, one per 2 cm for a hose) instead of the model's pi
    sections;
  - sensors: pressure transducers and the laser are first-order low-passes
    (random bandwidths), coloured (AR(1)) noise on top of white noise, a slow
    drift, a few outlier samples; the drive has a second harmonic
    (distortion) and the recorded drive has its own noise;
  - records start at rest, at the static state under the bias current, or
    mid-operation (after a run-in of tens of cycles) at a random phase;
  - the baseline parameters the thesis does not give (outlet-line bore,
    cylinder wetted length and area, accumulator volume, the drive's force
    per ampere) are drawn at random inside declared ranges.

The hidden effects are the same physics as the library's, written here in
their own form (the air's law is drawn: polytropic or constant modulus), plus
effects outside the library (reed stiction on its seat, magnetic saturation
of the transducer) whose verdict should be "beyond the library".

Units SI, pressures gauge about the bias inside; the CSV has absolute
pressures, as `rectify diagnose` reads them (docs/diagnosis.md, "Input").
"""
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

PSI = 6894.757
IN = 0.0254

# ---------------------------------------------------------------- nominal values (thesis Table A.1)
NOMINAL = dict(
    rho=873.0, mu=0.0386, beta=85e3 * PSI, gamma=1.4, p_bias=2.582e6,
    E_td=35e9, A_td=0.196 * IN**2, L_td=4.5 * IN, k_d=2.15e6, m_eff=0.124, zeta_t=0.09,
    turns=860.0, q_pm=6.85e-9, R_coil=1.9,
    h_ch=0.05 * IN, A_pi=0.785 * IN**2, zeta_f=0.55,
    k_r=6650.0, m_r=0.3643e-3, zeta_r=0.1285, A_r=0.0123 * IN**2,
    # the thesis's R(x): eq. 3.40 with its floor and closed value
    R_closed=1e17, R_fit0=2.34e11, R_fit_rate=0.025e6, R_floor=4.5e8,
    # baseline choices the thesis does not give: drawn in RANGES below
    # the pump's outlet passage to the cylinder: short (a compact manifold,
    # 1 cm), so that its inertance rings far above the pumping harmonics; the
    # hidden effect line_inertance is a hose instead
    line_d=4.572e-3, line_l=0.3048, outlet_line_l=0.01,
    A_po=0.2 * IN**2, wet_l=1.0 * IN, xi_h=0.5, V_gas=1.0 * IN**3,
    force_gain=1.0, load_mass=50 * 0.45359,
    # the reed's second bending mode / its first: 6.27 for a uniform
    # cantilever; drawn in MODE2_RATIO per record (an irregular reed in oil)
    mode2_ratio=6.27,
)

# The second mode's ratio to the first, drawn per record from its own stream
# (make_record.py): a plate reed in vacuum has 6.19 (docs/stiffness.md), the
# oil's added mass, which falls for the shorter wave, raises it; an irregular
# reed moves it either way.
MODE2_RATIO = (5.6, 7.0)

# Baseline parameters that the thesis does not give, drawn per record in these
# ranges. cases/reference.toml's [uncertain] table, which the study runs as a
# user would, declares wider ones that contain each of these (the oil column
# 0.005-0.3 m: a hose's volume on the high side included).
RANGES = dict(
    line_d=(3.5e-3, 6.0e-3),        # all four lines' bore
    wet_l=(0.5 * IN, 2.5 * IN),      # output-cylinder oil column
    A_po=(0.15 * IN**2, 0.3 * IN**2),  # output-cylinder area (loaded runs)
    V_gas=(0.5 * IN**3, 2.5 * IN**3),  # accumulator gas volume
    force_gain=(0.93, 1.07),        # the drive's force per ampere
)

# hidden effects: name -> (parameter, low, high, log); the study's ranges
EFFECTS = {
    "entrained_air": ("alpha", 4e-3, 1.5e-2, True),
    # a soft seal: 3-100x the high side's oil (C_h about 3e-15 m^3/Pa); far
    # beyond that the high side never charges within a record and any large
    # compliance, or a leak, looks the same
    "outlet_compliance": ("C_seal", 1e-14, 3e-13, True),
    "valve_leakage": ("R_leak", 5e10, 2e12, True),
    # a leak through a short, wide path (a nick in the seat): q = A sqrt(2 dp / rho),
    # about the laminar range's flows at 1 MPa (0.5-10 cm^3/s)
    "valve_leakage_turbulent": ("A_leak", 1e-8, 2e-7, True),
    "orifice_flow": ("Cd", 0.35, 0.5, False),
    # a hose of the lines' bore, 0.1-1 m long (4/3 rho l / A): lumped below its
    # quarter-wave frequency at the first harmonics (a longer hose rings
    # like a transmission line, which neither model here is)
    "line_inertance": ("L_line", 8e6, 4e7, True),
    "coil_dynamics": ("L_coil", 5e-4, 5e-3, True),
    "piston_friction": ("F_c", 4.0, 60.0, True),
    "reed_second_mode": ("f2", 2000.0, 3000.0, True),
    # beyond the library
    "reed_stiction": ("F_stick", 0.5, 3.0, True),
    "transducer_saturation": ("I_sat", 12.0, 25.0, False),
}
BEYOND_LIBRARY = ("reed_stiction", "transducer_saturation")


def resistance(x, P):
    """The thesis's R(x), log-linear between its samples (a discretisation of
    eq. 3.40 other than the diagnosis model's PCHIP), R_closed at and below 0
    blended to the fit over the first 0.2 um."""
    x_um = x * 1e6
    fit = max(P["R_fit0"] * math.exp(-P["R_fit_rate"] * x), P["R_floor"])
    if x_um >= 0.2:
        return fit
    if x_um <= 0.0:
        return P["R_closed"]
    w = x_um / 0.2
    return math.exp((1 - w) * math.log(P["R_closed"]) + w * math.log(fit))


class Pump:
    """The bench's model. `effect` is one of EFFECTS or None, `value` its
    parameter; `P` the parameter dict (NOMINAL updated with the draws)."""

    # outlet-line sections: at least 4 (the 1 cm manifold rings far above the
    # pumping harmonics), and one per 2 cm of a hose, so that a hose's modes
    # below 2 kHz are those of a continuous line within about 1 % (four
    # sections put a 0.74 m hose's second mode 10 % low, its third 20 %)
    MIN_SEG, SEG_LENGTH = 4, 0.02

    def __init__(self, P, scenario, effect=None, value=None, air_law="polytropic", drive=None, voltage=False):
        self.P, self.scenario, self.effect, self.value = P, scenario, effect, value
        self.air_law = air_law
        self.drive = drive            # I_true(t) or V(t) for a voltage drive
        self.voltage = voltage or effect == "coil_dynamics"
        p = P
        self.k_td = p["E_td"] * p["A_td"] / p["L_td"]
        self.k_eff = self.k_td + p["k_d"]
        self.b_t = 2 * p["zeta_t"] * math.sqrt(self.k_eff * p["m_eff"])
        self.m_f = p["rho"] * p["A_pi"] * p["h_ch"]
        self.k_f = p["beta"] * p["A_pi"] / p["h_ch"]
        self.b_f = 2 * p["zeta_f"] * math.sqrt(self.k_f * self.m_f)
        self.force_per_A = p["force_gain"] * p["turns"] * p["q_pm"] * self.k_td
        # reed: two modes, tip-normalised, equal modal masses
        self.f2 = value if effect == "reed_second_mode" else p["mode2_ratio"] * math.sqrt(p["k_r"] / p["m_r"]) / (2 * math.pi)
        self.k_r1 = p["k_r"]
        self.k_r2 = p["m_r"] * (2 * math.pi * self.f2) ** 2
        self.b_r1 = 2 * p["zeta_r"] * math.sqrt(self.k_r1 * p["m_r"])
        self.b_r2 = 2 * p["zeta_r"] * math.sqrt(self.k_r2 * p["m_r"])
        self.k_seat = p.get("seat_stiffness_factor", 1.0) * 1e5 * p["k_r"]  # 60 nm under a 40 N closing force
        self.b_seat = 2.0 * math.sqrt(self.k_seat * p["m_r"])
        # volumes and compliances
        self.V_ch = p["A_pi"] * p["h_ch"]
        self.V_h = p["A_po"] * p["xi_h"] * p["wet_l"]
        self.V_l = p["A_po"] * (1 - p["xi_h"]) * p["wet_l"]
        self.C_acc = p["V_gas"] / p["p_bias"]
        self.V_j = p.get("junction_volume_factor", 1.0) * 0.2e-6  # the inlet passages' junction: 0.2 cm^3 of oil
        # lines: Poiseuille resistance, the outlet line distributed
        R_line = lambda d, l: 128 * p["mu"] * l / (math.pi * d**4)
        self.R4 = self.R5 = self.R6 = R_line(p["line_d"], p["line_l"])
        d_out, l_out = p["line_d"], p["outlet_line_l"]
        area = math.pi * d_out**2 / 4
        self.R_out = R_line(d_out, l_out)
        self.L_out = 4.0 / 3.0 * p["rho"] * l_out / area  # laminar profile: 4/3 of rho l / A
        self.V_line = area * l_out
        if effect == "line_inertance":
            # a hose of the same bore, as long as the given inertance makes it:
            # its resistance and its oil's compliance grow with it
            scale = value / self.L_out
            self.L_out = value
            self.R_out *= scale
            self.V_line *= scale
            l_out *= scale
        else:  # the 1 cm passage (make_record --without passage scales its inertance)
            self.L_out *= p.get("outlet_passage_inertance_factor", 1.0)
        self.N_SEG = max(self.MIN_SEG, math.ceil(l_out / self.SEG_LENGTH - 1e-9))
        self.A_port = p["A_r"]
        self.perimeter = 2 * math.sqrt(math.pi * p["A_r"])
        # state layout
        names = ["x_p", "v_p", "x_f", "v_f", "x_act", "v_act",
                 "a1o", "w1o", "a2o", "w2o", "a1i", "w1i", "a2i", "w2i",
                 "p_ch", "p_acc", "p_h", "p_l", "p_seal", "I", "p_a"]
        names += [f"pn{k}" for k in range(self.N_SEG)] + [f"qs{k}" for k in range(self.N_SEG)]
        self.idx = {n: i for i, n in enumerate(names)}
        self.n = len(names)

    # -------------------------------------------------------------- fluid
    def air_compliance(self, V, p_gauge):
        if self.effect != "entrained_air":
            return 0.0
        P = self.P
        alpha, g, pb = self.value, P["gamma"], P["p_bias"]
        if self.air_law == "constant":
            return V * alpha / (g * pb)
        p_abs = max(pb + p_gauge, 0.01 * pb)
        return V * alpha * (pb / p_abs) ** (1 / g) / (g * p_abs)

    def compliance(self, V, p_gauge):
        return V / self.P["beta"] + self.air_compliance(V, p_gauge)

    def valve_flow(self, dp, x):
        """Flow through a valve at opening x under dp (chamber side first)."""
        R = resistance(x, self.P)
        q = dp / R
        if self.effect == "orifice_flow" and x > 0:
            # R q + K q|q| = dp, K = rho / (2 Cd^2 A^2), A = port perimeter x opening
            A = self.perimeter * x
            K = self.P["rho"] / (2 * self.value**2 * A**2)
            q = math.copysign(2 * abs(dp) / (R + math.sqrt(R * R + 4 * K * abs(dp))), dp)
        if self.effect == "valve_leakage":
            q += dp / self.value
        if self.effect == "valve_leakage_turbulent":
            q += self.turbulent_leak(dp)
        return q

    def turbulent_leak(self, dp):
        """An orifice leak, A sqrt(2|dp|/rho), laminar (linear) below 2 kPa,
        where the two meet."""
        p_t = 2e3
        if abs(dp) >= p_t:
            return math.copysign(self.value * math.sqrt(2 * abs(dp) / self.P["rho"]), dp)
        return dp / p_t * self.value * math.sqrt(2 * p_t / self.P["rho"])

    def inlet_flow(self, p_a, p_ch, x_i):
        """Flow from the junction into the chamber through R4 and the inlet
        valve in series: q = valve(p_a - R4 q - p_ch), solved by bisection
        on q (monotone), or directly when the valve is linear."""
        dp = p_a - p_ch
        if not (self.effect == "orifice_flow" and x_i > 0) and self.effect != "valve_leakage_turbulent":
            R2 = resistance(x_i, self.P)
            g = 1.0 / R2 + (1.0 / self.value if self.effect == "valve_leakage" else 0.0)
            return dp / (1.0 / g + self.R4)
        q_hi = dp / self.R4
        lo, hi = (0.0, q_hi) if dp >= 0 else (q_hi, 0.0)
        if self.effect == "valve_leakage_turbulent":  # Brent's method: a dozen flows, not 60
            if dp == 0.0:
                return 0.0
            return brentq(lambda q: self.valve_flow(dp - self.R4 * q, x_i) - q, lo, hi,
                          xtol=1e-14 * abs(q_hi), rtol=1e-13)
        for _ in range(60):
            q = 0.5 * (lo + hi)
            if self.valve_flow(dp - self.R4 * q, x_i) > q:
                lo = q
            else:
                hi = q
        return 0.5 * (lo + hi)

    # -------------------------------------------------------------- right-hand side
    def rhs(self, t, y):
        P, i = self.P, self.idx
        d = np.zeros(self.n)
        # drive
        if self.voltage:
            V = self.drive(t)
            L = self.value if self.effect == "coil_dynamics" else 0.0
            if L > 0:
                d[i["I"]] = (V - P["R_coil"] * y[i["I"]]) / L
                I = y[i["I"]]
            else:
                I = V / P["R_coil"]
        else:
            I = self.drive(t)
        if self.effect == "transducer_saturation":
            I = self.value * math.tanh(I / self.value)
        F = self.force_per_A * I
        x_p, v_p, x_f, v_f = y[i["x_p"]], y[i["v_p"]], y[i["x_f"]], y[i["v_f"]]
        p_ch, p_acc, p_h, p_l = y[i["p_ch"]], y[i["p_acc"]], y[i["p_h"]], y[i["p_l"]]
        # transducer and chamber fluid mass
        spring = self.k_f * (x_p - x_f) + self.b_f * (v_p - v_f)
        d[i["x_p"]] = v_p
        d[i["v_p"]] = (F - self.k_eff * x_p - self.b_t * v_p - spring) / P["m_eff"]
        d[i["x_f"]] = v_f
        d[i["v_f"]] = (spring - p_ch * P["A_pi"]) / self.m_f
        # reeds (outlet: chamber -> line node 0; inlet: junction -> chamber)
        x_o = y[i["a1o"]] + y[i["a2o"]]
        x_i = y[i["a1i"]] + y[i["a2i"]]
        p_n0 = y[i["pn0"]]
        # junction: a small oil volume (a state; the diagnosis model solves it algebraically)
        p_a = y[i["p_a"]]
        # the inlet branch: line R4 in series with the valve; p_i between them
        # solved by a few Newton steps on R4 q + valve(p_i - p_ch) = ... (linear unless orifice)
        q_in = self.inlet_flow(p_a, p_ch, x_i)
        q_out = self.valve_flow(p_ch - p_n0, x_o)
        p_i = p_a - self.R4 * q_in  # upstream of the inlet reed
        dp_o = p_ch - p_n0
        dp_i = p_i - p_ch
        for side, x, dp in (("o", x_o, dp_o), ("i", x_i, dp_i)):
            v = y[i["w1" + side]] + y[i["w2" + side]]
            Fp = P["A_r"] * dp
            if x < 0:
                Fp += max(0.0, -self.k_seat * x - self.b_seat * v)  # never pulls
            if self.effect == "reed_stiction":
                # adhesion of the oil film on the seat land: pulls the reed back within ~2 um
                Fp -= self.value * math.exp(-max(x, 0.0) / 2e-6)
            for m, k, b in (("1", self.k_r1, self.b_r1), ("2", self.k_r2, self.b_r2)):
                a, w = y[i["a" + m + side]], y[i["w" + m + side]]
                d[i["a" + m + side]] = w
                d[i["w" + m + side]] = (Fp - k * a - b * w) / P["m_r"]
        # chamber
        d[i["p_ch"]] = (P["A_pi"] * v_p + q_in - q_out) / self.compliance(self.V_ch, p_ch)
        # outlet line: nodes 0..N-1, segment k from node k to node k+1 (node N: the high side)
        N = self.N_SEG
        Cn = self.V_line / N
        for k in range(N):
            p_k = y[i[f"pn{k}"]]
            p_next = y[i[f"pn{k + 1}"]] if k + 1 < N else p_h
            q_k = y[i[f"qs{k}"]]
            d[i[f"qs{k}"]] = (p_k - p_next - self.R_out / N * q_k) / (self.L_out / N)
            q_into = q_out if k == 0 else y[i[f"qs{k - 1}"]]
            d[i[f"pn{k}"]] = (q_into - q_k) / self.compliance(Cn, p_k)
        q_line = y[i[f"qs{N - 1}"]]
        # high side, with a soft seal (compliance behind a small resistance, a viscoelastic lip)
        v_act = y[i["v_act"]] if self.scenario == "loaded" else 0.0
        q_seal = 0.0
        if self.effect == "outlet_compliance":
            tau = self.P.get("seal_time_constant", 1e-4)  # make_record --without lip: 1e-7, follows at once
            q_seal = (p_h - y[i["p_seal"]]) * self.value / tau
            d[i["p_seal"]] = (p_h - y[i["p_seal"]]) / tau
        d[i["p_h"]] = (q_line - P["A_po"] * v_act - q_seal) / self.compliance(self.V_h, p_h)
        d[i["p_a"]] = (-q_in - (p_a - p_acc) / self.R5 - (p_a - p_l) / self.R6) / self.compliance(self.V_j, p_a)
        d[i["p_acc"]] = (p_a - p_acc) / self.R5 / self.C_acc
        d[i["p_l"]] = ((p_a - p_l) / self.R6 + P["A_po"] * v_act) / self.compliance(self.V_l, p_l)
        if self.scenario == "loaded":
            f = (p_h - p_l) * P["A_po"]
            if self.effect == "piston_friction":
                # Coulomb with a Stribeck rise at low speed (the library: tanh(v / 1 mm/s))
                vs = 2e-3
                f -= self.value * (1 + 0.3 * math.exp(-(v_act / vs) ** 2)) * math.tanh(v_act / 0.5e-3)
            d[i["x_act"]] = v_act
            d[i["v_act"]] = f / P["load_mass"]
        return d

    def outputs(self, y):
        i = self.idx
        pb = self.P["p_bias"]
        return dict(
            outlet_pressure_Pa=pb + y[i["pn0"]],  # the transducer at the pump's outlet, behind the valve
            chamber_pressure_Pa=pb + y[i["p_ch"]],
            outlet_valve_m=y[i["a1o"]] + y[i["a2o"]],
            strain=y[i["x_p"]] / self.P["L_td"],
            actuator_position_m=y[i["x_act"]],
            actuator_velocity_m_per_s=y[i["v_act"]],
        )


def integrate(pump, t0, t1, y0, t_eval=None, rtol=1e-7):
    sol = solve_ivp(pump.rhs, (t0, t1), y0, method="LSODA", t_eval=t_eval, rtol=rtol,
                    atol=_atol(pump), max_step=(t1 - t0) / 20)
    if not sol.success:
        raise RuntimeError(f"bench integration failed at t = {sol.t[-1]:.6g} s: {sol.message}")
    return sol


def _atol(pump):
    a = np.empty(pump.n)
    for name, k in pump.idx.items():
        if name.startswith(("p", "pn")):
            a[k] = 1.0  # Pa
        elif name.startswith("qs"):
            a[k] = 1e-12
        elif name.startswith(("a", "x")):
            a[k] = 1e-10
        elif name == "I":
            a[k] = 1e-6
        else:
            a[k] = 1e-9
    return a
