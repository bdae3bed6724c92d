"""Draws the benchmark's diagrams and writes summary.md from the CSVs in a folder.

Usage: bench_report.py DIR   (DIR holds work_precision.csv, orders.csv, scaling.csv, peers_*.csv,
                              and optionally scenes.csv and trees.csv)
Writes: work_precision.png (one panel per scenario), scaling.png, peers.png, peers.csv (merged),
summary.md (headline numbers, orders, scaling exponent, peer table).
"""
import csv
import math
import pathlib
import sys

import matplotlib

import performance_page  # the tables docs/ shows, one copy

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COMMAND = "bash scripts/bench.sh"
DIVERGED = 1.0  # [m]


read = performance_page.read
fit_slope = performance_page.fit_slope


COLORS = {"explicit_euler": "C0", "semi_implicit_euler": "C1", "midpoint": "C2", "rk4": "C3",
          "velocity_verlet": "C4", "dopri5": "C5", "fast_projection": "C6"}
STYLES = {"none": ":", "baumgarte": "--", "projection": "-", "rattle": "-"}


def method_label(row):
    if row["integrator"] == "velocity_verlet":
        return "velocity_verlet (rattle)"
    if row["integrator"] == "fast_projection":
        return "fast_projection"
    return f"{row['integrator']} + {row['stabilization']}"


def work_precision(out, rows):
    scenarios = list(dict.fromkeys(r["scenario"] for r in rows))
    cols = 3
    fig, axes = plt.subplots(math.ceil(len(scenarios) / cols), cols,
                             figsize=(6 * cols, 4.8 * math.ceil(len(scenarios) / cols)), squeeze=False)
    for ax, scenario in zip(axes.flat, scenarios):
        curves = {}
        for r in rows:
            if r["scenario"] != scenario or r["finite"] != "1":
                continue
            error, cost = float(r["error_m"]), float(r["cpu_s_per_sim_s"])
            # a diverged run (error above 1 m) is in the CSV, not on the curve
            if not (math.isfinite(error) and 0 < error <= DIVERGED and cost > 0):
                continue
            # the methods that hold the constraints themselves are drawn solid like projection
            holds = r["integrator"] in ("velocity_verlet", "fast_projection")
            stabilization = "rattle" if holds else r["stabilization"]
            curves.setdefault((method_label(r), r["integrator"], stabilization), []).append((cost, error))
        for (label, integrator, stabilization), points in sorted(curves.items()):
            points.sort()
            ax.loglog([p[0] for p in points], [p[1] for p in points], STYLES[stabilization],
                      color=COLORS[integrator], marker="o", markersize=3, label=label)
        ax.set_title(scenario)
        ax.set_xlabel("CPU time per simulated second [s]")
        ax.set_ylabel("position error at t = 1 s [m]")
        ax.grid(True, which="both", alpha=0.3)
    for ax in list(axes.flat)[len(scenarios):]:
        ax.axis("off")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8)
    fig.suptitle("Work-precision: error against cost, one curve per method (dt swept; dopri5: tolerance "
                 "swept; runs with error > 1 m left out)\nColour: integrator; line: dotted none, dashed "
                 "Baumgarte, solid projection")
    fig.tight_layout(rect=(0, 0.08, 1, 0.95))
    fig.savefig(out / "work_precision.png", dpi=90)
    plt.close(fig)


def best_methods(rows, scenario, targets=(1e-3, 1e-6, 1e-9)):
    """Cheapest finite run reaching each error target."""
    lines = []
    for target in targets:
        candidates = [r for r in rows if r["scenario"] == scenario and r["finite"] == "1"
                      and math.isfinite(float(r["error_m"])) and float(r["error_m"]) <= target]
        if not candidates:
            lines.append((target, None))
            continue
        best = min(candidates, key=lambda r: float(r["cpu_s_per_sim_s"]))
        lines.append((target, best))
    return lines


def scaling(out, rows):
    fig, ax = plt.subplots(figsize=(7, 5))
    fits = {}
    series = {}
    for r in rows:
        series.setdefault((r["integrator"], r["solve"]), []).append(
            (int(r["n"]), float(r["seconds_per_step"])))
    for (integrator, solve), points in sorted(series.items()):
        points.sort()
        ax.loglog([p[0] for p in points], [p[1] for p in points], marker="o",
                  label=f"{integrator} + projection, {solve} solve")
        big = [p for p in points if 1000 <= p[0] <= 100000]
        if len(big) >= 2:
            fits[(integrator, solve)] = fit_slope([p[0] for p in big], [p[1] for p in big])
    ax.set_xlabel("particles n")
    ax.set_ylabel("CPU time per step [s]")
    ax.set_title("Chain: time per step against n")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "scaling.png", dpi=90)
    plt.close(fig)
    return fits


def peers(out):
    rows = []
    for path in sorted(out.glob("peers_*.csv")):
        rows += read(path)
    with open(out / "peers.csv", "w", newline="") as f:
        if rows:
            writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            writer.writeheader()
            writer.writerows(rows)
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 5))
    series = {}
    for r in rows:
        series.setdefault(f"{r['engine']} {r['method']}", []).append(r)
    for label, points in sorted(series.items()):
        points.sort(key=lambda r: int(r["n"]))
        ns = [int(r["n"]) for r in points]
        left.loglog(ns, [float(r["time_per_step_s"]) for r in points], marker="o", label=label)
        finite = [r for r in points if r["finite"] == "1"]
        right.loglog([int(r["n"]) for r in finite],
                     [max(float(r["link_error_max_m"]), 1e-16) for r in finite], marker="o", label=label)
    left.set_title("time per step (pinned chain, dt = 1 ms)")
    left.set_xlabel("particles n")
    left.set_ylabel("CPU time per step [s]")
    right.set_title("max link-length error over the run (finite runs)")
    right.set_xlabel("particles n")
    right.set_ylabel("max | |p_i - p_j| - l | [m]")
    for ax in (left, right):
        ax.grid(True, which="both", alpha=0.3)
    right.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "peers.png", dpi=90)
    plt.close(fig)
    return rows


def main(folder):
    out = pathlib.Path(folder)
    wp = read(out / "work_precision.csv")
    work_precision(out, wp)
    orders = read(out / "orders.csv")
    scale_rows = read(out / "scaling.csv")
    fits = scaling(out, scale_rows)
    peer_rows = peers(out)

    lines = ["# Benchmark summary", "",
             f"Produced by `{COMMAND}` (CPU times are thread CPU time; medians of repeated runs "
             "where a run is short). Machine: shared 2-core VM.", ""]
    lines += ["## Observed convergence orders (bead on a bowl, circular orbit, closed-form reference)", "",
              "| integrator | stabilization | theoretical | observed |", "|---|---|---|---|"]
    for r in orders:
        if r["scenario"] == "bead_bowl":
            observed = r["observed_order"]
            shown = f"{float(observed):.2f}" if observed != "nan" else "n/a"
            lines.append(f"| {r['integrator']} | {r['stabilization']} | {r['theoretical_order']} | {shown} |")
    lines += ["", "## Cheapest method reaching an error (position error at t = 1 s)", "",
              "| scenario | error <= | method | dt | CPU s per sim s |", "|---|---|---|---|---|"]
    for scenario in dict.fromkeys(r["scenario"] for r in wp):
        for target, best in best_methods(wp, scenario):
            if best is None:
                lines.append(f"| {scenario} | {target:g} m | none reached it | | |")
            else:
                tolerance = f", tol {best['tolerance']}" if best["integrator"] == "dopri5" else ""
                lines.append(f"| {scenario} | {target:g} m | {method_label(best)}{tolerance} | "
                             f"{best['dt']} | {float(best['cpu_s_per_sim_s']):.3g} |")
    lines += ["", "## Scaling of the chain (time per step against n)", "",
              "| integrator | solve | n | time per step [s] | particle-steps per second |", "|---|---|---|---|---|"]
    for r in scale_rows:
        if int(r["n"]) in (1000, 10000, 100000):
            lines.append(f"| {r['integrator']} | {r['solve']} | {r['n']} | {float(r['seconds_per_step']):.3g} | "
                         f"{float(r['particle_steps_per_second']):.3g} |")
    lines += ["", "Fitted exponent of time per step against n, n = 1,000 to 100,000:", ""]
    for (integrator, solve), slope in sorted(fits.items()):
        lines.append(f"- {integrator} + projection, {solve} solve: {slope:.2f}")
    lines += ["", "## Peers: pinned chain under gravity, dt = 1 ms, 10 s", "",
              "| engine | method | n | time per step [s] | max link error [m] | mean link error [m] | finite | note |",
              "|---|---|---|---|---|---|---|---|"]
    for r in sorted(peer_rows, key=lambda r: (int(r["n"]), r["engine"], r["method"])):
        lines.append(f"| {r['engine']} | {r['method']} | {r['n']} | {float(r['time_per_step_s']):.3g} | "
                     f"{float(r['link_error_max_m']):.3g} | {float(r['link_error_mean_m']):.3g} | "
                     f"{'yes' if r['finite'] == '1' else 'no'} | {r['note']} |")
    lines += scenes_section(out)
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def scenes_section(out):
    """Per scene file: effects evaluated per step and step cost; the tree solve against n (the
    tables docs/scenes.md shows, from scripts/performance_page.py)."""
    if not (out / "scenes.csv").exists():
        return []
    lines = ["", "## Scenes: what each evaluates per step, and what a step costs", "",
             "Counts are evaluations per step from the effect counters (RK4 evaluates forces 4 "
             "times a step; projection adds row evaluations).", ""] + performance_page.scene_rows(out)
    if not (out / "trees.csv").exists():
        return lines
    lines += ["", "## Solve by structure: one constraint-force evaluation against n", "",
              "binary_tree: particle k hangs from (k - 1) / 2, the root pinned; star: every "
              "particle linked to one free hub (J W J^T is dense). tree: as it runs (the binary tree, "
              "all links with at most four on a particle: the fused tree stages, "
              "Model::fusedTree(); the star: the block elimination); tree, blocks: the generic "
              "stages with the block elimination (tree.cpp), which the generic paths and stars "
              "keep.", ""]
    return lines + performance_page.tree_rows(out)[0]


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "docs/bench")
