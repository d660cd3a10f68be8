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
    cols = [c for c in t if c.endswith('_mean_velocity_m_per_s') and '_not_valid_' not in c]
    f = t['frequency_Hz']
    out = {}
    for name in cols:
        v = t[name]
        v = [-math.inf if math.isnan(x) else x for x in v]  # NaN: a failed run
        i = max(range(len(v)), key=lambda k: v[k])
        first_rev = next((f[k] for k in range(len(v)) if f[k] > 100 and -math.inf < v[k] < 0), float('nan'))
        below = [k for k in range(len(v)) if not f[k] >= first_rev]
        j = max(below, key=lambda k: v[k])
        out[name] = (v[i], f[i], first_rev, v[j], f[j])
    return out


def validity(run):
    """Per series of the loaded velocity sweep: runs, runs not valid and why,
    the worst Goodman factor, and the first reversal and peak from the valid
    runs alone (sweep-runs.csv; an older sweep without the columns: None)."""
    with open(run / 'loaded/velocity/sweep-runs.csv') as f:
        rows = list(csv.DictReader(f))
    if not rows or 'valid' not in rows[0]:
        return None
    out = {}
    for r in sorted(rows, key=lambda r: float(r['frequency_Hz'])):
        s = out.setdefault(r['series'], {'n': 0, 'not_valid': 0, 'goodman': math.inf, 'valid': [],
                                         'flags': {k: 0 for k in ('beyond_map', 'beyond_stop', 'below_cavitation_pressure',
                                                                  'goodman_below_1', 'at_stop', 'cavitating')}})
        if r['regime'].startswith('failed'):
            continue
        s['n'] += 1
        s['not_valid'] += r['valid'] != '1'
        for k in s['flags']:
            s['flags'][k] += r[k] == '1'
        s['goodman'] = min(s['goodman'], float(r['goodman_factor']))
        if r['valid'] == '1':
            s['valid'].append((float(r['frequency_Hz']), float(r['mean_velocity_m_per_s'])))
    for s in out.values():
        pts = s['valid']
        rev = next((pts[k][0] for k in range(1, len(pts)) if pts[k][0] > 100 and pts[k][1] < 0 < pts[k - 1][1]),
                   float('nan'))
        below = [p for p in pts if not p[0] >= rev]
        s['peak'] = max(below, key=lambda p: p[1]) if below else (float('nan'), float('nan'))
        s['reversal'] = rev
    return out


def trace1420(run):
    """The loaded 1420 Hz run's state (its summary.json 'run' block)."""
    import json
    with open(run / 'loaded/trace-1420Hz/summary.json') as f:
        r = json.load(f)['run']
    valid = r.get('validity', {}).get('valid')
    goodman = min((v.get('goodman_factor') or math.inf for v in r.get('valves', {}).values()), default=math.nan)
    return (r['max_outlet_reed_opening_m'], r['max_inlet_reed_opening_m'], r['min_absolute_chamber_pressure_Pa'],
            r['samples_beyond_map'], valid, goodman, r.get('stop_impacts', 0))


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
        for key, fn in (('traces', traces), ('stored', stored), ('velocity', velocity), ('phase', phase),
                        ('validity', validity), ('trace1420', trace1420)):
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
        except (TypeError, KeyError):
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
    row('1420 Hz: max outlet / inlet reed opening [mm]',
        lambda r: '{:.2f} / {:.2f}'.format(r['trace1420'][0] * 1e3, r['trace1420'][1] * 1e3))
    row('1420 Hz: min absolute chamber pressure [MPa]', lambda r: f'{r["trace1420"][2] * 1e-6:.2f}')
    row('1420 Hz: samples beyond the map; stop impacts', lambda r: f'{r["trace1420"][3]}; {r["trace1420"][6]}')
    row('1420 Hz: valid; worst Goodman factor', lambda r: '{}; {:.2f}'.format(
        'yes' if r['trace1420'][4] else 'no', r['trace1420'][5]))
    for series in ('dynamic', 'reed-whatif'):
        v = lambda r: r['validity'][series]
        row(f'{series}: runs not valid of the sweep', lambda r: f'{v(r)["not_valid"]} of {v(r)["n"]}')
        row(f'{series}: ... beyond map / through stop / below cavitation / Goodman < 1',
            lambda r: ' / '.join(str(v(r)['flags'][k]) for k in ('beyond_map', 'beyond_stop',
                                                                 'below_cavitation_pressure', 'goodman_below_1')))
        row(f'{series}: runs at the stop / cavitating', lambda r: '{} / {}'.format(v(r)['flags']['at_stop'],
                                                                                  v(r)['flags']['cavitating']))
        row(f'{series}: worst Goodman factor', lambda r: f'{v(r)["goodman"]:.2f}')
        row(f'{series}: valid runs only: first reversal [Hz]; peak [m/s] at [Hz]',
            lambda r: '{:.0f}; {:.3f} at {:.0f}'.format(v(r)['reversal'], v(r)['peak'][1], v(r)['peak'][0]))


if __name__ == '__main__':
    main()
