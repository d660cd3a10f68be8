#!/usr/bin/env python3
"""The chapter-5 numbers of docs/chapter5-comparison.md, from the outputs of
scripts/reference.sh: for the model on the thesis's R(x) (RUN/), on the
valve's own FE maps (RUN/fe-maps/) and on those maps with the reed's fluid
loading (RUN/fe-loading/, docs/fluid-loading.md). Prints a Markdown table.

Usage: python3 scripts/chapter5_numbers.py runs/reference [LABEL=DIR ...]
(each LABEL=DIR adds a column for a chapter-5 set in DIR, such as the film
variants of docs/fluid-loading.md; RUN alone: the thesis's, FE maps, and
RUN/fe-loading if it exists)
"""
import csv
import math
import sys
from pathlib import Path

PSI = 6894.757


def table(path):
    with open(path) as f:
        rows = [r for r in csv.reader(line for line in f if not line.startswith('#'))]
    head = rows[0]
    return {h: [float(r[i]) for r in rows[1:]] for i, h in enumerate(head)}


def traces(run):
    out = {}
    for f in (5, 10, 25, 50):
        t = table(run / f'no-flow/trace-{f}Hz/timeseries.csv')
        out[f] = max(t['outlet_pressure_Pa']) / PSI
    return out


def stored(run):
    t = table(run / 'no-flow/stored-pressure/sweep.csv')
    f, dyn = t['frequency_Hz'], t['dynamic_stored_pressure_Pa'] if 'dynamic_stored_pressure_Pa' in t else t[list(t)[1]]
    low = [p for fi, p in zip(f, dyn) if fi <= 20 and not math.isnan(p)]  # NaN: a failed run
    level = sum(low) / len(low)
    half = next((fi for fi, p in zip(f, dyn) if fi > 20 and p < 0.5 * level), float('nan'))
    return level / PSI, half, dyn[-1] / PSI


def velocity(run):
    t = table(run / 'loaded/velocity/sweep.csv')
    cols = list(t)
    f = t['frequency_Hz']
    out = {}
    for name in cols[1:]:
        v = t[name]
        v = [-math.inf if math.isnan(x) else x for x in v]  # NaN: a failed run
        i = max(range(len(v)), key=lambda k: v[k])
        first_rev = next((f[k] for k in range(len(v)) if f[k] > 100 and -math.inf < v[k] < 0), float('nan'))
        below = [k for k in range(len(v)) if not f[k] >= first_rev]
        j = max(below, key=lambda k: v[k])
        out[name] = (v[i], f[i], first_rev, v[j], f[j])
    return out


def phase(run):
    """Lag of the outlet reed's opening behind the piston's flow A_pi x_p',
    as a fraction of the cycle: the peak of their cross-correlation over the
    last 20 cycles."""
    t = table(run / 'loaded/trace-1420Hz/timeseries.csv')
    time, q, xro = t['time_s'], t['piston_flow_m3_per_s'], t['outlet_reed_m']
    n = len(time)
    per_cycle = round((1 / 1420.0) / (time[1] - time[0]))
    start = n - 20 * per_cycle
    vp, xr = q[start:], xro[start:]
    mp, mr = sum(vp) / len(vp), sum(xr) / len(xr)
    vp = [v - mp for v in vp]
    xr = [x - mr for x in xr]
    best, lag_best = -math.inf, 0
    for lag in range(per_cycle):
        c = sum(vp[k] * xr[(k + lag) % len(xr)] for k in range(len(vp) - per_cycle))
        if c > best:
            best, lag_best = c, lag
    return lag_best / per_cycle


def main():
    run = Path(sys.argv[1])
    variants = [('thesis R(x), A_r', run), ('FE maps', run / 'fe-maps')]
    if (run / 'fe-loading').is_dir():
        variants.append(('FE maps + fluid loading', run / 'fe-loading'))
    for extra in sys.argv[2:]:
        label, _, d = extra.partition('=')
        if not d:
            sys.exit(f'chapter5_numbers.py: {extra!r}: expected LABEL=DIR')
        variants.append((label, Path(d)))
    def results(d):
        out = {}
        for key, fn in (('traces', traces), ('stored', stored), ('velocity', velocity), ('phase', phase)):
            try:
                out[key] = fn(d)
            except (OSError, KeyError, ValueError):
                out[key] = None  # a run that did not finish (reported by reference.sh)
        return out

    res = {name: results(d) for name, d in variants}
    names = [n for n, _ in variants]
    print('| result | ' + ' | '.join(names) + ' |')
    print('|---|' + '---:|' * len(names))
    def cell(fn, r):
        try:
            return fn(r)
        except TypeError:
            return 'n/a'

    row = lambda label, fn: print(f'| {label} | ' + ' | '.join(cell(fn, res[n]) for n in names) + ' |')
    row('no-flow peak p_o at 5/10/25/50 Hz, 20 A p-p [psi]',
        lambda r: ' / '.join(f'{r["traces"][f]:.0f}' for f in (5, 10, 25, 50)))
    row('stored pressure up to 20 Hz, 4 A p-p [psi]', lambda r: f'{r["stored"][0]:.0f}')
    row('first frequency with stored pressure below half that [Hz]', lambda r: f'{r["stored"][1]:.0f}')
    row('stored pressure at 1200 Hz [psi]', lambda r: f'{r["stored"][2]:.0f}')
    for series in ('dynamic', 'ideal', 'reed-whatif'):
        key = lambda r: next(k for k in r['velocity'] if k.startswith(series))
        row(f'{series}: peak velocity below the first reversal [m/s] at [Hz]',
            lambda r: '{:.3f} at {:.0f}'.format(*r['velocity'][key(r)][3:5]))
        row(f'{series}: highest velocity of the sweep [m/s] at [Hz]',
            lambda r: '{:.3f} at {:.0f}'.format(*r['velocity'][key(r)][:2]))
        row(f'{series}: first reversal above 100 Hz [Hz]', lambda r: f'{r["velocity"][key(r)][2]:.0f}')
    row('outlet reed lag behind the piston flow at 1420 Hz [cycle]', lambda r: f'{r["phase"]:.2f}')


if __name__ == '__main__':
    main()
