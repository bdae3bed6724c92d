#!/usr/bin/env python3
"""Draws a ~compare_methods study's work-precision diagram with matplotlib.

Usage: plot_compare_methods.py STUDY.csv OUT.png [--raw OUT.rgba] [--title TEXT]

STUDY.csv is what the action writes (or scripts/compare_methods.py merges): one line per run.
The diagram: position error at the horizon [m] against CPU time per simulated second [s], log-log,
one line per method (integrator + stabilisation across dt; dopri5 across tolerances), the error
target as a dashed line, the reference's own error shaded (errors below it are not resolved), and
the recommended run circled. --raw also writes "width height\\n" and the RGBA bytes, which the
node publishes as a sensor_msgs/Image on ~compare_methods/diagram.
"""
import argparse
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")  # headless: no display needed
import matplotlib.pyplot as plt  # noqa: E402


def read_runs(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def method_key(row):
    if row["integrator"] in ("velocity_verlet", "fast_projection"):
        return row["integrator"] + " (projects itself)"
    return row["integrator"] + " + " + row["stabilization"]


def draw(rows, out_png, title):
    figure, axes = plt.subplots(figsize=(9, 6), dpi=100)
    lines = {}
    for row in rows:
        error = float(row["position_error_m"])
        cost = float(row["cpu_s_per_sim_s"])
        if row["finite"] != "1" or not math.isfinite(error) or error <= 0 or cost <= 0:
            continue
        lines.setdefault(method_key(row), []).append((cost, error, row))
    markers = "os^vD<>ph*x+"
    for k, (label, points) in enumerate(sorted(lines.items())):
        points.sort(key=lambda p: p[0])
        axes.loglog([p[0] for p in points], [p[1] for p in points], "-" + markers[k % len(markers)],
                    label=label, markersize=4, linewidth=1)
    target = float(rows[0]["error_target_m"]) if rows else float("nan")
    reference = max((float(r["reference_error_m"]) for r in rows), default=0.0)
    if math.isfinite(target):
        axes.axhline(target, color="k", linestyle="--", linewidth=1,
                     label="error target %.3g m" % target)
    if reference > 0:
        axes.axhspan(axes.get_ylim()[0], reference, color="0.85", zorder=0,
                     label="below the reference's error %.2g m" % reference)
    chosen = [r for r in rows if r["recommended"] == "1"]
    for r in chosen:
        axes.loglog(float(r["cpu_s_per_sim_s"]), float(r["position_error_m"]), "o",
                    markersize=16, markerfacecolor="none", markeredgecolor="red", markeredgewidth=2,
                    label="recommended: %s, dt %s" % (method_key(r), r["dt_s"]))
    horizon = rows[0]["horizon_s"] if rows else "?"
    axes.set_xlabel("CPU time per simulated second [s]")
    axes.set_ylabel("position error at t = %s s against the reference [m]" % horizon)
    axes.set_title("What accuracy costs: %s" % title)
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=7, loc="best")
    figure.tight_layout()
    figure.savefig(out_png)
    return figure


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv")
    parser.add_argument("png")
    parser.add_argument("--raw", help="also write width height, then RGBA bytes, here")
    parser.add_argument("--title", default="")
    args = parser.parse_args()
    rows = read_runs(args.csv)
    if not rows:
        sys.exit("%s holds no runs" % args.csv)
    figure = draw(rows, args.png, args.title or args.csv)
    if args.raw:
        figure.canvas.draw()
        width, height = figure.canvas.get_width_height()
        with open(args.raw, "wb") as f:
            f.write(b"%d %d\n" % (width, height))
            f.write(bytes(figure.canvas.buffer_rgba()))


if __name__ == "__main__":
    main()
