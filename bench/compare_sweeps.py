#!/usr/bin/env python3
"""Compares two sweeps' tables of runs (sweep-runs.csv), e.g. before and after
a change meant to make the sweep faster without changing its answer
(docs/benchmarks.md, issue 18):

  python3 bench/compare_sweeps.py BEFORE/sweep-runs.csv AFTER/sweep-runs.csv

A point that was periodic (period 1) before must keep its metric (mean
velocity, or stored pressure in a no-flow sweep) within 0.5 % (the
tolerance study of docs/system-model.md) of the larger of its value and 2 %
of the sweep's largest value (a mean near zero has no relative size). Every
other point (period-k, non-periodic: valve flutter) is a sample mean whose
standard error each run reports (batch means): the two must agree within
three combined standard errors, or within the same 0.5 % band. Prints
every point that does not, the counts and the worst ratios, and exits 1 if
any point fails. Uses the Python standard library only.

  python3 bench/compare_sweeps.py BEFORE AFTER --perturbed BEFORE2 [--perturbed BEFORE3 ...]

With BEFORE2, ..., the same sweep as BEFORE under perturbations that should
not matter (e.g. --rtol 1.0001e-5): a point where BEFORE and one of them
already differ beyond the allowed difference has no reproducible answer (coexisting
responses, chaotic valve flutter, a start-up that settles by chance; see
docs/benchmarks.md). Such points are listed apart and do not fail.
"""
import csv
import json
import math
import os
import sys


def read(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"{path}: no runs")
    return {(r["series"], float(r["frequency_Hz"])): r for r in rows}


def allowed_ratio(b, a, metric, largest):
    """|difference| over the allowed difference (see the module's text)."""
    vb, va = float(b[metric]), float(a[metric])
    band = 5e-3 * max(abs(vb), 0.02 * largest)
    if b["regime"] == "periodic":
        return abs(va - vb) / band
    se = math.hypot(float(b["metric_stderr"]), float(a["metric_stderr"]))
    return min(abs(va - vb) / band, abs(va - vb) / (3 * se) if se > 0 else math.inf)


def main():
    args = sys.argv[1:]
    perturbed = []
    while "--perturbed" in args:
        i = args.index("--perturbed")
        if i + 1 >= len(args):
            sys.exit(__doc__)
        perturbed.append(read(args[i + 1]))
        del args[i:i + 2]
    if len(args) != 2:
        sys.exit(__doc__)
    before, after = read(args[0]), read(args[1])
    if before.keys() != after.keys() or any(p.keys() != before.keys() for p in perturbed):
        sys.exit("the sweeps have different series or frequencies")
    # The metric: the sweep's own summary (beside its table) names the scenario.
    summary = os.path.join(os.path.dirname(os.path.abspath(args[0])), "summary.json")
    try:
        with open(summary) as f:
            no_flow = json.load(f)["scenario"] == "no-flow"
    except (OSError, KeyError, ValueError):
        sys.exit(f"{summary}: cannot read the sweep's scenario")
    metric = "stored_pressure_Pa" if no_flow else "mean_velocity_m_per_s"
    largest = max(abs(float(r[metric])) for r in before.values())
    n_periodic = n_other = 0
    worst_periodic = worst_other = 0.0
    failures, unreproducible = [], []
    for key in sorted(before):
        b, a = before[key], after[key]
        ratio = allowed_ratio(b, a, metric, largest)
        text = (f"  {key[0]} {key[1]:.6g} Hz ({b['regime']} -> {a['regime']}): "
                f"{float(b[metric]):.6g} -> {float(a[metric]):.6g}, {ratio:.2f} x the allowed difference")
        if any(allowed_ratio(b, p[key], metric, largest) > 1 for p in perturbed):
            others = ", ".join(f"{float(p[key][metric]):.6g}" for p in perturbed)
            unreproducible.append(text + f" (perturbed before: {others})")
            continue
        if b["regime"] == "periodic":
            n_periodic += 1
            worst_periodic = max(worst_periodic, ratio)
        else:
            n_other += 1
            worst_other = max(worst_other, ratio)
        if ratio > 1:
            failures.append(text)
    print(f"{metric}: {n_periodic} periodic points, worst {worst_periodic:.2f} x 0.5 %; "
          f"{n_other} other points, worst {worst_other:.2f} x (3 combined standard errors or 0.5 %)")
    for line in failures:
        print(line)
    if perturbed:
        print(f"{len(unreproducible)} points without a reproducible answer (before vs perturbed before), not compared:")
        for line in unreproducible:
            print(line)
    print(f"{len(failures)} of {len(before) - len(unreproducible)} compared points differ beyond the allowed difference")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
