#!/usr/bin/env python3
"""Observed order of accuracy from a ~compare_methods CSV (scripts/compare_methods_demo.sh).

For each fixed-step integrator + stabilisation, the position error at each dt and the observed
order between successive dt decades, log10(e(dt) / e(dt / 10)): about 4 for RK4 on smooth
motion, dropping towards 1 where the run crosses an event the step does not resolve (an impact
found at the end of the step it happened in, a contact leaving at a step's start). Errors within
ten times the reference's own error (reference_error_m) are not resolved and get no order.
Prints a Markdown table. The standard library's csv module reads the file.

Usage: scripts/observed_orders.py CSV [--integrators rk4,midpoint,...]
"""
import argparse
import csv
import math
import sys


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("csv", help="a <scene>_compare_methods.csv")
    parser.add_argument("--integrators", default="", help="comma-separated names (default: all)")
    args = parser.parse_args()
    wanted = [name for name in args.integrators.split(",") if name]
    runs = {}
    reference = 0.0
    with open(args.csv, newline="") as f:
        for row in csv.DictReader(f):
            if float(row["tolerance"]) > 0.0:  # adaptive runs have no dt sequence
                continue
            if wanted and row["integrator"] not in wanted:
                continue
            reference = float(row["reference_error_m"])
            key = (row["integrator"], row["stabilization"])
            error = float(row["position_error_m"]) if row["finite"] == "1" else math.nan
            runs.setdefault(key, []).append((float(row["dt_s"]), error))
    if not runs:
        sys.exit(f"{args.csv}: no fixed-step runs")
    dts = sorted({dt for series in runs.values() for dt, _ in series}, reverse=True)
    header = ["method"] + [f"error, dt {dt:g} s [m]" for dt in dts]
    header += [f"order {a:g} -> {b:g}" for a, b in zip(dts, dts[1:])]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for (integrator, stabilization), series in runs.items():
        error_at = dict(series)
        cells = [f"{integrator} + {stabilization}"]
        cells += [f"{error_at[dt]:.2e}" if dt in error_at else "" for dt in dts]
        for a, b in zip(dts, dts[1:]):
            ea, eb = error_at.get(a, math.nan), error_at.get(b, math.nan)
            resolved = all(e > 10.0 * reference for e in (ea, eb))  # NaN: not
            cells.append(f"{math.log10(ea / eb) / math.log10(a / b):.2f}" if resolved else "-")
        print("| " + " | ".join(cells) + " |")
    print(f"\nreference error {reference:.1e} m: errors within 10 times it get no order (-)")


if __name__ == "__main__":
    main()
