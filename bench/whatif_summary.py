#!/usr/bin/env python3
"""The numbers docs/whatif.md quotes from a what-if batch's whatif.csv: the
table over designs and power-law fits (log-log least squares) of k_r and
f1 against the varied key.
    python3 bench/whatif_summary.py OUT [KEY]"""
import csv, math, sys

out = sys.argv[1]
rows = list(csv.DictReader(open(f"{out}/whatif.csv")))
key = sys.argv[2] if len(sys.argv) > 2 else [c for c in rows[0] if "." in c][0]


def num(r, c):
    try:
        return float(r[c])
    except (ValueError, KeyError):
        return float("nan")


def fmt(v, f="%.4g"):
    return "-" if math.isnan(v) else f % v


print(f"| {key} | k_r [N/m] | f1 vac / oil [Hz] | m_r eq. 3.21 [mg] | R(10 um) [Pa s/m^3] | R(100 um) | "
      "A_eff(100 um) [mm^2] | openings | peak velocity [mm/s] at [Hz] | first reversal [Hz] | "
      "stored p, 1 Hz [psi] | half at [Hz] | status |")
print("|" + "---:|" * 12 + "---|")
for r in rows:
    print(f"| {fmt(num(r, key) * 1e3, '%.4g')} mm | {fmt(num(r, 'k_r_N_per_m'), '%.5g')} | "
          f"{fmt(num(r, 'f1_vacuum_Hz'), '%.0f')} / {fmt(num(r, 'f1_oil_Hz'), '%.0f')} | "
          f"{fmt(num(r, 'm_r_eq321_kg') * 1e6, '%.1f')} | {fmt(num(r, 'R_10um_Pa_s_per_m3'), '%.4g')} | "
          f"{fmt(num(r, 'R_100um_Pa_s_per_m3'), '%.4g')} | {fmt(num(r, 'A_eff_100um_m2') * 1e6, '%.3f')} | "
          f"{fmt(num(r, 'map_openings'), '%.0f')} | {fmt(num(r, 'peak_velocity_m_per_s') * 1e3, '%.1f')} at "
          f"{fmt(num(r, 'peak_velocity_frequency_Hz'), '%.0f')} | {fmt(num(r, 'bandwidth_Hz'), '%.0f')} | "
          f"{fmt(num(r, 'stored_pressure_low_Pa') / 6894.757, '%.0f')} | "
          f"{fmt(num(r, 'half_pressure_frequency_Hz'), '%.0f')} | {r['status']} |")


def power_law(col):
    pts = [(math.log(num(r, key)), math.log(num(r, col))) for r in rows
           if num(r, key) > 0 and num(r, col) > 0]
    n = len(pts)
    if n < 2:
        return float("nan"), 0
    mx = sum(p[0] for p in pts) / n
    my = sum(p[1] for p in pts) / n
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    sxy = sum((p[0] - mx) * (p[1] - my) for p in pts)
    b = sxy / sxx
    worst = max(abs(p[1] - (my + b * (p[0] - mx))) for p in pts)
    return b, math.expm1(worst)


for col in ["k_r_N_per_m", "f1_vacuum_Hz", "f1_oil_Hz", "m_r_eq321_kg", "R_10um_Pa_s_per_m3",
            "R_100um_Pa_s_per_m3", "A_eff_100um_m2"]:
    b, worst = power_law(col)
    print(f"{col} ~ {key}^{b:.3f} (largest miss of the power law {100 * worst:.2f} %)")
