"""Fills the generated blocks of docs/*.md from the files the measuring commands write (most in
docs/bench/; the study in docs/compare_methods/).

A block is the text between `<!-- generated: NAME -->` and `<!-- end generated -->`; everything
else on the page is hand-written and holds no measured figure and no commit hash
(scripts/check_docs.py checks the hashes). Each block starts with the stamp of the run its files
come from: the line the command that wrote them left beside them (`<name>.stamp`: the command,
the commit and the date). The commands: `bash scripts/bench.sh`, `scripts/compare_cores.sh
--csv`, `scripts/node_kernel_ratio.py --csv`, `scripts/node_rates.sh --csv`,
`scripts/default_substeps.sh --csv`, `scripts/hard_cases.sh --csv`, `scripts/energy_sweep.sh`, `scripts/compare_methods_demo.sh`,
`scripts/reliability.sh`, `scripts/tier_times.sh`; each refills the pages when it is done
(`write_measurement` for the Python ones).

    python3 scripts/performance_page.py [ROOT]     (the commands run it after they write)
    python3 scripts/performance_page.py --stamp [ROOT]   (prints the stamp the scripts write)

A block whose files are missing says which command writes them; a block name with no generator
stops it with the page as it was.
"""
import csv
import math
import pathlib
import re
import sys

BLOCK = re.compile(r"(<!-- generated: (\w+) -->\n)(.*?)(<!-- end generated -->)", re.S)


def stamp(root):
    """'commit abc1234, 2026-12-05' for the tree at `root` ('+ uncommitted changes' if a tracked
    file outside docs/ differs from it): the one place a commit hash may stand on the page."""
    import subprocess
    import datetime

    def git(*args):
        return subprocess.run(["git", "-C", str(root), *args], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True).stdout.strip()

    commit = git("rev-parse", "--short", "HEAD") or "unknown"
    # docs/ is what the measuring commands write: a change there does not change what is measured
    # untracked files count too: CMake and compare_cores.sh pick sources up by glob
    changed = git("status", "--porcelain", "--", ".", ":!docs")
    dirty = " + uncommitted changes" if changed else ""
    return f"commit {commit}{dirty}, {datetime.date.today().isoformat()}"


def read(path):
    with open(path, newline="") as f:
        return [r for r in csv.DictReader(f)]


def fit_slope(xs, ys):
    lx, ly = [math.log(x) for x in xs], [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)


def us(seconds):
    """A time [s] in the unit that reads best: 0.85 us, 62 us, 8.3 ms, 17 s."""
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6)):
        if seconds >= scale or unit == "us":
            value = seconds / scale
            return f"{value:.3g} {unit}"


def write_measurement(root, path, header, rows, how):
    """Writes a measuring command's table to `path` (CSV: `header`, then `rows`, cells as given)
    and its stamp beside it (`how`: the command and its settings, then the commit and date), and
    refills the pages when `path` is in docs/bench (test_docs checks the pages match it)."""
    root = pathlib.Path(root)
    path = pathlib.Path(path)
    with open(path, "w", newline="") as f:
        out = csv.writer(f, lineterminator="\n")
        out.writerow(header)
        out.writerows(rows)
    path.with_suffix(".stamp").write_text(f"{how} at {stamp(root)}\n")
    if path.resolve().parent == (root / "docs" / "bench").resolve():
        fill(root)


def stamp_line(text):
    return f"_{text.strip()}_\n\n"


def stamp_of(bench, stem):
    """The stamp the command that wrote `<stem>.csv` left beside it as `<stem>.stamp`: the
    command, and the commit and date it ran at."""
    return (bench / f"{stem}.stamp").read_text().strip()


def orders_block(bench):
    rows = [r for r in read(bench / "orders.csv") if r["scenario"] == "bead_bowl"]
    table = {}
    for r in rows:
        observed = r["observed_order"]
        table.setdefault((r["integrator"], r["theoretical_order"]), {})[r["stabilization"]] = (
            f"{float(observed):.2f}" if observed != "nan" else "n/a")
    lines = ["| integrator | theory | none | Baumgarte | projection | its own projection |",
             "|---|---|---|---|---|---|"]
    for (integrator, theory), by in table.items():
        cells = [by.get(s, "") for s in ("none", "baumgarte", "projection", "rattle")]
        lines.append(f"| {integrator} | {theory} | " + " | ".join(cells) + " |")
    return stamp_line(f"From {stamp_of(bench, 'orders')} (`docs/bench/orders.csv`).") + "\n".join(lines) + "\n"


def best(rows, scenario, target):
    found = [r for r in rows if r["scenario"] == scenario and r["finite"] == "1"
             and math.isfinite(float(r["error_m"])) and float(r["error_m"]) <= target]
    return min(found, key=lambda r: float(r["cpu_s_per_sim_s"])) if found else None


def method_of(r):
    if r["integrator"] == "dopri5":
        return f"dopri5, tolerance {float(r['tolerance']):g}"
    if r["integrator"] in ("velocity_verlet", "fast_projection"):
        return f"{r['integrator']}, dt = {float(r['dt']) * 1e3:g} ms"
    return f"{r['integrator']} + {r['stabilization']}, dt = {float(r['dt']) * 1e3:g} ms"


def headline_block(bench):
    scaling = read(bench / "scaling.csv")
    by = {(r["integrator"], r["solve"], int(r["n"])): float(r["seconds_per_step"]) for r in scaling}
    lines = ["| figure | value | file |", "|---|---|---|"]
    for integrator, label in (("semi_implicit_euler", "semi-implicit Euler"), ("rk4", "RK4")):
        t = by.get((integrator, "tridiagonal", 100000))
        if t:
            lines.append(f"| chain of 100,000, {label} + projection, O(n) solve | {us(t)} per step = "
                         f"**{1e5 / t / 1e6:.1f} million particle-steps/s** | `scaling.csv` |")
    for integrator, label in (("semi_implicit_euler", "semi-implicit Euler"), ("rk4", "RK4")):
        t = by.get((integrator, "tridiagonal", 1000))
        if t:
            lines.append(f"| same, {label}, n = 1,000 (fits in cache) | {us(t)} per step = "
                         f"{1e3 / t / 1e6:.1f} million particle-steps/s | `scaling.csv` |")
    for (integrator, solve) in sorted({(k[0], k[1]) for k in by}):
        points = sorted((n, t) for (i, s, n), t in by.items()
                        if (i, s) == (integrator, solve) and 1000 <= n <= 100000)
        if len(points) >= 2:
            lines.append(f"| fitted exponent of time per step against n, {integrator}, {solve} "
                         f"solve, n = {points[0][0]:,} ... {points[-1][0]:,} | "
                         f"**{fit_slope(*zip(*points)):.2f}** | `scaling.csv` |")
    dense, fast = by.get(("semi_implicit_euler", "dense", 1000)), by.get(
        ("semi_implicit_euler", "tridiagonal", 1000))
    if dense and fast:
        lines.append(f"| dense solve at n = 1,000 (for comparison) | {us(dense)} per step, "
                     f"{dense / fast:,.0f}x the O(n) solve | `scaling.csv` |")
    wp = read(bench / "work_precision.csv")
    for scenario, target, label in (("bead_bowl", 1e-6, "the bead orbit"),
                                    ("chain_100", 1e-9, "the 100-particle chain")):
        r = best(wp, scenario, target)
        if r:
            lines.append(f"| cheapest run to {target:g} m on {label} | {method_of(r)}: "
                         f"{us(float(r['cpu_s_per_sim_s']))} CPU per simulated second | "
                         f"`work_precision.csv` |")
    return stamp_line(f"From {stamp_of(bench, 'scaling')}.") + "\n".join(lines) + "\n"


PEER_LABELS = {
    "rk4+projection": "**constrained_particles, RK4 + projection**",
    "rk4+projection_tol_1e-13": "constrained_particles, RK4 + projection to 1e-13 m",
    "velocity_verlet": "constrained_particles, velocity Verlet",
    "semi_implicit_euler+projection": "constrained_particles, semi-implicit Euler + projection",
    "quickstep_gazebo_defaults": "ODE, QuickStep (Gazebo's settings)",
    "worldstep_direct": "ODE, dWorldStep",
    "nested_ball_joints_rk4": "MuJoCo, ball joints, RK4",
}


def peers_block(bench):
    rows = read(bench / "peers.csv")
    lines = ["| n | engine, method | time per step | max link error | finite over the run | note |",
             "|---|---|---|---|---|---|"]
    order = list(PEER_LABELS)
    rows.sort(key=lambda r: (int(r["n"]), order.index(r["method"]) if r["method"] in order else 99))
    for r in rows:
        finite = r["finite"] == "1"
        error = f"{float(r['link_error_max_m']):.2g} m" if finite else "-"
        diverged_at = int(r["steps_run"]) * float(r["dt"])
        held = "yes" if finite else f"no: diverged at t = {diverged_at:.2f} s"
        label = PEER_LABELS.get(r["method"], r["engine"] + ", " + r["method"])
        lines.append(f"| {r['n']} | {label} | {us(float(r['time_per_step_s']))} | {error} | "
                     f"{held} | {r['note']} |")
    # the comparisons the prose draws, from the same rows
    ours = {int(r["n"]): r for r in rows if r["method"] == "rk4+projection"}
    tight = {int(r["n"]): r for r in rows if r["method"] == "rk4+projection_tol_1e-13"}
    summary = []
    for engine, methods in (("ODE", ("quickstep_gazebo_defaults", "worldstep_direct")),
                            ("MuJoCo", ("nested_ball_joints_rk4",))):
        ratios = [float(r["time_per_step_s"]) / float(ours[int(r["n"])]["time_per_step_s"])
                  for r in rows if r["method"] in methods and int(r["n"]) in ours]
        if ratios:
            summary.append(f"RK4 + projection's step is {min(ratios):.3g}x to {max(ratios):.3g}x "
                           f"faster than {engine}'s over the sizes and methods")
    extra = [float(tight[n]["time_per_step_s"]) / float(ours[n]["time_per_step_s"]) - 1
             for n in sorted(tight) if n in ours]
    if extra:
        summary.append(f"projection to 1e-13 m costs {100 * min(extra):+.0f} % to "
                       f"{100 * max(extra):+.0f} % time per step over 1e-10 m")
    text = stamp_line(f"From {stamp_of(bench, 'peers')} (`docs/bench/peers.csv`; all three engines "
                      "timed in the same run).") + "\n".join(lines) + "\n"
    if summary:
        text += "\nIn this run: " + "; ".join(summary) + ".\n"
    return text


def table_block(bench, stem, header, cells):
    """docs/bench/<stem>.csv as a table under its stamp: `header` the column names, `cells(row)`
    a row's cells."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cells(r)) + " |" for r in read(bench / f"{stem}.csv")]
    return stamp_line(f"From {stamp_of(bench, stem)} (`docs/bench/{stem}.csv`).") + "\n".join(lines) + "\n"


def us_of(row, key):
    """A CSV time [s] as microseconds, 3 digits."""
    return f"{1e6 * float(row[key]):.3g}"


def cores_block(bench):
    return table_block(
        bench, "cores",
        ["workload", "method", "old [us/step]", "new [us/step]", "new / old", "positions differ [m]"],
        lambda r: [r["workload"], r["integrator"], us_of(r, "old_seconds_per_step"),
                   us_of(r, "new_seconds_per_step"), f"{float(r['ratio']):.2f}",
                   f"{float(r['max_position_difference_m']):.2g}"])


def self_collision_block(bench):
    return table_block(
        bench, "self_collision",
        ["n", "link pairs", "self-collision [us]", "floor only [us]", "free chain [us]",
         "self-collision / free", "self-collision / floor only", "closest links - 2 r [m]"],
        lambda r: [f"{int(r['n']):,}", f"{int(r['link_pairs']):,}",
                   f"{float(r['self_collision_us_per_particle_step']):.3g}",
                   f"{float(r['floor_only_us_per_particle_step']):.3g}",
                   f"{float(r['free_us_per_particle_step']):.3g}",
                   f"{float(r['self_collision_over_free']):.0f}",
                   f"{float(r['self_collision_over_floor_only']):.1f}",
                   f"{float(r['closest_links_less_2r_m']):.2g}"])


def contact_block(bench):
    """docs/bench/contact.csv (bench/contact_chain.cpp): the chain lying on a plane with and
    without contact, and the exponents its '# exponent' lines give."""
    rows = read(bench / "contact.csv")
    measured = [r for r in rows if not r["n"].startswith("#")]
    lines = ["| n | with contact (tree) | with contact (sparse) | no contact (fused) | "
             "no contact (generic, sparse) | contact / fused | contact / generic |",
             "|---|---|---|---|---|---|---|"]
    for r in measured:
        lines.append("| " + " | ".join(
            [f"{int(r['n']):,}"] +
            [f"{float(r[k]):#.3g}" for k in ("contact_us_per_particle_step",
                                             "contact_sparse_us_per_particle_step",
                                             "free_fused_us_per_particle_step",
                                             "free_generic_sparse_us_per_particle_step")] +
            [f"{float(r[k]):.1f}" for k in ("contact_over_fused", "contact_over_generic")]) + " |")
    exponents = [(r["n"][len("# exponent "):], r["contact_us_per_particle_step"]) for r in rows
                 if r["n"].startswith("# exponent")]
    text = "\n".join(lines) + "\n"
    if exponents:
        text += "\nThe cost per step's exponent in n: " + "; ".join(
            f"{name}, {float(value):.3f}" for name, value in exponents) + ".\n"
    return stamp_line(f"From {stamp_of(bench, 'contact')} (`docs/bench/contact.csv`).") + text


def kernel_block(bench):
    def cells(r):
        checked = bool(r.get("checked_s_per_step"))
        return [f"{int(r['n']):,}", f"{float(r['max_position_difference_m']):.2g}",
                us_of(r, "engine_s_per_step"), us_of(r, "kernel_s_per_step"),
                us_of(r, "generic_s_per_step"), us_of(r, "checked_s_per_step") if checked else "-",
                f"{float(r['ratio_median']):.2f} ({float(r['ratio_min']):.2f} to "
                f"{float(r['ratio_max']):.2f})", f"{float(r['generic_ratio_median']):.2f}",
                f"{float(r['checked_ratio_median']):.2f}" if checked else "-"]

    return table_block(bench, "kernel",
                       ["n", "positions differ after 1 s [m]", "engine [us/step]", "kernel [us/step]",
                        "generic [us/step]", "checked [us/step]", "e/k (range of rounds)", "g/k",
                        "c/k"], cells)


def node_kernel_block(bench, stem="node_kernel"):
    return table_block(
        bench, stem,
        ["n", "node `step_time` [us]", "kernel [us]", "node / kernel (median; range of rounds)"],
        lambda r: [f"{int(r['n']):,}", us_of(r, "node_s_per_step"), us_of(r, "kernel_s_per_step"),
                   f"{float(r['ratio_median']):.2f} ({float(r['ratio_min']):.2f} to "
                   f"{float(r['ratio_max']):.2f})"])


def node_engine_block(bench):
    """The node against the core's own step on the same chain at the node's settings, each
    round from rest (docs/bench/node_engine.csv): the runner's own work (issue 47)."""
    return table_block(
        bench, "node_engine",
        ["n", "node `step_time` [us]", "core step [us]", "node / core (median; range of rounds)"],
        lambda r: [f"{int(r['n']):,}", us_of(r, "node_s_per_step"), us_of(r, "kernel_s_per_step"),
                   f"{float(r['ratio_median']):.2f} ({float(r['ratio_min']):.2f} to "
                   f"{float(r['ratio_max']):.2f})"])


def node_rates_block(bench):
    """The node's throughput at 1,000 to 100,000 particles (docs/bench/node_rates.csv), for
    docs/node.md."""
    return table_block(
        bench, "node_rates",
        ["particles", "steps/s", "real-time factor", "/tf [Hz]", "~state [Hz]", "~particles [Hz]",
         "node CPU [%]"],
        lambda r: [f"{int(r['n']):,}", f"{float(r['steps_per_s']):,.0f}",
                   f"{float(r['real_time_factor']):.3g}", f"{float(r['tf_hz']):.1f}",
                   f"{float(r['state_hz']):.1f}", f"{float(r['particles_hz']):.1f}",
                   f"{float(r['node_cpu_percent']):.0f}"])


def substeps_case(case):
    """default_substeps.sh's case name in words."""
    match = re.match(r"(peer|unsplit)_(\d+)_(\w+)$", case)
    if match:
        kind, n, integrator = match.groups()
        split = "default sub-steps" if kind == "peer" else "`max_substeps: 1`"
        return f"the peer chain of {n}, `{integrator}`, {split}"
    if case == "taut_chain_gravity":
        return "20 particles taut between two pins under gravity, `rk4`, default sub-steps"
    return case


def default_substeps_block(bench):
    """The peer chains and the taut chain at the node's default sub-steps
    (docs/bench/default_substeps.csv), for docs/physics.md."""
    return table_block(
        bench, "default_substeps",
        ["run", "sim time [s]", "energy drift [J]", "largest link error [m]"],
        lambda r: [substeps_case(r["case"]), r["sim_seconds"],
                   f"{float(r['energy_drift_J']):+.3g}", f"{float(r['max_position_error_m']):.2g}"])


def energy_sweep_block(bench):
    """The energy sweep's outcomes in a few lines (docs/bench/energy_sweep.csv), for
    docs/physics.md; docs/energy_sweep.md has every run."""
    runs = read(bench / "energy_sweep.csv")
    ok = [r for r in runs if r["outcome"] == "ok"]
    handed = [r for r in ok if int(r["stiff_steps"])]
    stopped = {}
    for r in runs:
        if r["outcome"] != "ok":
            stopped.setdefault((r["integrator"], r["stabilization"]), []).append(r["scene"])
    horizon = max(float(r["time_s"]) for r in runs)
    unjudged = [r for r in ok if r.get("judged", "1") == "0"]
    lines = [f"- {len(runs)} runs; {len(ok)} reach {horizon:g} s, {len(ok) - len(unjudged)} of "
             f"them within the energy budget and {len(unjudged)} in scenes it does not judge "
             f"(sampled holders, carried shapes, friction: their share of it is a figure in "
             f"[energy_sweep.md](energy_sweep.md)), {len(handed)} handed to `fast_projection` "
             f"on the way;",
             f"- {len(runs) - len(ok)} stop on a named step check:"]
    lines += [f"  - `{integrator}` under `{stabilization}`: {len(scenes)} "
              f"({', '.join(sorted(scenes))})" for (integrator, stabilization), scenes in
              sorted(stopped.items(), key=lambda item: (-len(item[1]), item[0]))]
    # what the budget would have said where it does not judge: a gap, written down
    free = [r for r in runs if r.get("judged", "1") == "0"]
    over = sorted((r for r in free if float(r["max_residual_over_budget"]) > 1.0),
                  key=lambda r: -float(r["max_residual_over_budget"]))
    if over:
        worst = over[0]
        methods = sorted({r["integrator"] for r in over})
        lines.append(f"- of the {len(free)} runs in scenes the budget does not judge, {len(over)} "
                     f"went over it at some point, up to "
                     f"{float(worst['max_residual_over_budget']):.0f}x (`{worst['scene']}`, "
                     f"`{worst['integrator']}` under `{worst['stabilization']}`), all with "
                     + " or ".join(f"`{m}`" for m in methods))
    return (stamp_line(f"From {stamp_of(bench, 'energy_sweep')} (`docs/bench/energy_sweep.csv`).")
            + "\n".join(lines) + "\n")


def energy_sweep_stamp_block(bench):
    return stamp_line(f"From {stamp_of(bench, 'energy_sweep')}.")


def compare_methods_block(bench):
    """The study of docs/compare_methods/ (scripts/compare_methods_demo.sh) in a few lines, for
    docs/accuracy.md: the recommendation, and per integrator its cheapest run within the target
    or, if none is, its most accurate run."""
    folder = bench.parent / "compare_methods"
    runs = [r for r in read(folder / "surface_chain_compare_methods.csv") if r["finite"] == "1"]
    target = float(runs[0]["error_target_m"])
    error, cpu = (lambda r: float(r["position_error_m"])), (lambda r: float(r["cpu_s_per_sim_s"]))

    def method(r):
        tolerance = f", tolerance {float(r['tolerance']):g}" if float(r["tolerance"]) else ""
        return f"{r['integrator']} + {r['stabilization']}, dt = {float(r['dt_s']):g} s{tolerance}"

    times = lambda x: f"{x:,.0f}" if x >= 100 else f"{x:.2g}"
    best = next(r for r in runs if r["recommended"] == "1")
    lines = [f"For {target:g} m at t = {float(best['horizon_s']):g} s the cheapest is "
             f"{method(best)} ({error(best):.2g} m, {cpu(best):.2g} s CPU per simulated second). "
             "Each integrator's cheapest run within the target, or its most accurate one:", "",
             "| integrator | run | error [m] | error / target | CPU x the recommended |",
             "|---|---|---|---|---|"]
    for integrator in dict.fromkeys(r["integrator"] for r in runs):
        mine = [r for r in runs if r["integrator"] == integrator]
        within = [r for r in mine if error(r) <= target]
        r = min(within, key=cpu) if within else min(mine, key=error)
        lines.append(f"| {integrator} | {method(r)} | {error(r):.2g} | {error(r) / target:.2g} | "
                     f"{times(cpu(r) / cpu(best))} |")
    stem = "compare_methods/surface_chain_compare_methods"
    return (stamp_line(f"From {(bench.parent / (stem + '.stamp')).read_text().strip()} "
                       f"(`docs/{stem}.csv`).") + "\n".join(lines) + "\n")


RELIABILITY_PARTS = [
    ("fuzz_services", "service fuzzing",
     "`CP_FUZZ_SUMMARY=FILE rostest constrained_particles fuzz_services.test` (also in `scripts/test.sh`)"),
    ("fuzz", "core fuzzing (libFuzzer + ASan + UBSan)", "`bash scripts/fuzz.sh 300`"),
    ("tsan", "data races (ThreadSanitizer), every rostest", "`bash scripts/tsan.sh`"),
    ("realtime", "real time: 1,000 particles, dt = 1 ms, a busy loop on the other core; then more "
     "than the machine can do (20,000 particles, the loop on the node's core)",
     "`bash scripts/realtime_load.sh`")]


def reliability_block(bench):
    """docs/reliability.md's table: each part's result line as `scripts/reliability.sh PART` kept
    it (docs/bench/reliability_PART.txt), with its own stamp."""
    lines = ["| what | command | result | run |", "|---|---|---|---|"]
    for part, what, command in RELIABILITY_PARTS:
        try:
            result = "; ".join((bench / f"reliability_{part}.txt").read_text().strip().split("\n"))
            run = stamp_of(bench, f"reliability_{part}")
        except OSError:
            result, run = "not measured yet", f"`bash scripts/reliability.sh {part}` writes it"
        lines.append(f"| {what} | {command} | {result.replace('|', '/')} | {run} |")
    return stamp_line("Each row from its own run (`docs/bench/reliability_*.txt`).") + "\n".join(lines) + "\n"


def tiers_block(bench):
    """How long each test tier takes (docs/bench/tiers.csv), for docs/testing.md."""
    minutes = lambda seconds: f"{int(seconds) // 60} min {int(seconds) % 60:02d} s"
    return table_block(
        bench, "tiers", ["tier", "tests passed", "wall time", "gtests", "rostests"],
        lambda r: [f"`bash scripts/test.sh{' --long' if r['tier'] == 'long' else ''}`",
                   r["tests_passed"], minutes(float(r["wall_s"])), minutes(float(r["gtest_s"])),
                   minutes(float(r["rostest_s"]))])


def hard_cases_block(bench):
    """The hard cases' measured figures (docs/bench/hard_cases.csv), under docs/stability.md's
    table of what the tests assert."""
    rows = read(bench / "hard_cases.csv")
    return (stamp_line(f"From {stamp_of(bench, 'hard_cases')} (`docs/bench/hard_cases.csv`).") +
            "\n".join(f"- {r['case']}: {r['figures']}" for r in rows) + "\n")


def instructions_block(bench):
    text = (bench / "kernel_instructions.txt").read_text().strip().split("\n")
    stamps = [line[2:] for line in text if line.startswith("# ")]
    counts = [line for line in text if not line.startswith("#")]
    return (stamp_line("From " + "; ".join(stamps) + " (`docs/bench/kernel_instructions.txt`).") +
            "\n".join(f"- {line}" for line in counts) + "\n")


def scene_rows(bench):
    """The per-scene table's lines (docs/bench/scenes.csv)."""
    lines = ["| scene | particles | rows | solve | integrator + stabilization | stages | "
             "us per step | on the generic stages | ratio | forces per step | "
             "constraints per step |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in read(bench / "scenes.csv"):
        generic = r.get("generic_seconds_per_step")
        generic = f"{1e6 * float(generic):.3g}" if generic else "-"
        ratio = r.get("generic_ratio_median")
        ratio = f"{float(ratio):.2f}" if ratio else "-"
        lines.append(f"| {r['scene']} | {r['particles']} | {r['rows']} | {r['solve']} | "
                     f"{r['integrator']} + {r['stabilization']} | {r.get('stages') or '-'} | "
                     f"{1e6 * float(r['seconds_per_step']):.3g} | {generic} | {ratio} | "
                     f"{r['forces_per_step']} | {r['constraints_per_step']} |")
    return lines


def tree_rows(bench):
    """The solve-by-structure table's lines and the fitted exponents (docs/bench/trees.csv)."""
    rows = read(bench / "trees.csv")
    table = {}
    for r in rows:
        table.setdefault((r["shape"], int(r["n"])), {})[r["solve"]] = 1e6 * float(r["seconds_per_solve"])
    lines = ["| shape | n | tree [us] | tree, blocks [us] | sparse [us] | dense [us] |",
             "|---|---|---|---|---|---|"]
    for (shape, n), by_solve in sorted(table.items()):
        cells = [f"{by_solve[s]:.3g}" if s in by_solve else "-"
                 for s in ("tree", "tree_blocks", "sparse", "dense")]
        lines.append(f"| {shape} | {n} | " + " | ".join(cells) + " |")
    lines += ["", "Fitted exponent of the tree solve's time against n (n >= 1,000):", ""]
    for shape in ("binary_tree", "star"):
        points = [(int(r["n"]), float(r["seconds_per_solve"])) for r in rows
                  if r["shape"] == shape and r["solve"] == "tree" and int(r["n"]) >= 1000]
        if len(points) >= 2:
            lines.append(f"- {shape}: {fit_slope(*zip(*points)):.2f}")
    return lines, table


def scenes_block(bench):
    lines = scene_rows(bench)
    ratios = {}
    for r in read(bench / "scenes.csv"):
        if r.get("generic_ratio_median"):
            ratios.setdefault(r.get("stages") or "-", []).append(float(r["generic_ratio_median"]))
    spans = [f"{stages} {min(v):.2f} to {max(v):.2f}" for stages, v in ratios.items() if v]
    return (stamp_line(f"From {stamp_of(bench, 'scenes')} (`docs/bench/scenes.csv`).") + "\n".join(lines) +
            "\n\nRatio to the generic stages, by stages: " + "; ".join(spans) + ".\n")


def trees_block(bench):
    lines, table = tree_rows(bench)
    fused = [f"{by['tree'] / by['tree_blocks']:.2f} (n = {n:,})" for (shape, n), by in sorted(table.items())
             if shape == "binary_tree" and "tree" in by and "tree_blocks" in by]
    text = stamp_line(f"From {stamp_of(bench, 'trees')} (`docs/bench/trees.csv`).") + "\n".join(lines) + "\n"
    if fused:
        text += ("\nOn the binary tree the fused tree stages take " + ", ".join(fused) +
                 " of the block elimination's time.\n")
    return text


STABILITY_METHODS = {"rk4 unsplit": "`rk4`, `max_substeps: 1`", "rk4 + sub-steps": "`rk4` (default)",
                     "velocity_verlet + sub-steps": "`velocity_verlet` (default sub-steps)"}


def stability_block(bench):
    """The fine chains' cost of staying stable (docs/bench/stability.csv), for docs/stability.md."""
    rows = read(bench / "stability.csv")
    lines = ["| n | method | sim time reached [s] | CPU s per sim s | x unsplit `rk4` | "
             "sub-steps per step | retaken | max constraint error [m] | energy change [J] |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        method = STABILITY_METHODS.get(r["method"], f"`{r['method']}`")
        if r["method"].startswith("fast_projection"):
            method = f"`fast_projection`, dt {float(r['dt_s']) * 1e3:g} ms"
        failed = r["failed_check"] != "none"
        reached = r["sim_seconds_reached"] + (f" (stopped: {r['failed_check']})" if failed else "")
        lines.append(
            f"| {int(r['n']):,} | {method} | {reached} | {float(r['cpu_s_per_sim_s']):.3g} | "
            f"{float(r['cost_ratio_to_unsplit_rk4']):.2f} | {float(r['substeps_per_step']):.3g} | "
            f"{r['rejected_steps']} | "
            f"{'-' if failed else format(float(r['max_constraint_error_m']), '.2g')} | "
            f"{'-' if failed else format(float(r['energy_change_J']), '+.3g')} |")
    return stamp_line(f"From {stamp_of(bench, 'stability')} (`docs/bench/stability.csv`).") + "\n".join(lines) + "\n"


# the command that writes each block's files
NOT_MEASURED = {"cores": "`bash scripts/bench.sh --cores BASE`",
                "node_kernel": "`scripts/node_kernel_ratio.py --csv docs/bench/node_kernel.csv`",
                "node_paced": "`scripts/node_kernel_ratio.py --drive rate --sizes 10 --csv "
                              "docs/bench/node_paced.csv`",
                "node_engine": "`scripts/node_kernel_ratio.py --against checked --sizes 1000 "
                               "10000 100000 --warmup 0.5 --csv docs/bench/node_engine.csv`",
                "instructions": "`bash scripts/kernel_instructions.sh > "
                                "docs/bench/kernel_instructions.txt`",
                "node_rates": "`bash scripts/node_rates.sh --check-particles-hz 10 --csv "
                              "docs/bench/node_rates.csv`",
                "default_substeps": "`bash scripts/default_substeps.sh --csv "
                                    "docs/bench/default_substeps.csv`",
                "energy_sweep": "`bash scripts/energy_sweep.sh`",
                "energy_sweep_stamp": "`bash scripts/energy_sweep.sh`",
                "compare_methods": "`bash scripts/compare_methods_demo.sh`",
                "tiers": "`bash scripts/tier_times.sh`",
                "hard_cases": "`bash scripts/hard_cases.sh --csv docs/bench/hard_cases.csv`",
                "self_collision": "`bash scripts/bench.sh --self-collision`",
                "contact": "`bash scripts/bench.sh --contact`"}
BLOCKS = {"stability": stability_block, "scenes": scenes_block, "trees": trees_block, "orders": orders_block, "headline": headline_block, "peers": peers_block,
          "cores": cores_block, "kernel": kernel_block, "node_kernel": node_kernel_block,
          "node_engine": node_engine_block,
          "node_paced": lambda bench: node_kernel_block(bench, "node_paced"),
          "instructions": instructions_block, "node_rates": node_rates_block,
          "default_substeps": default_substeps_block, "energy_sweep": energy_sweep_block,
          "energy_sweep_stamp": energy_sweep_stamp_block, "compare_methods": compare_methods_block,
          "reliability": reliability_block, "tiers": tiers_block,
          "hard_cases": hard_cases_block, "self_collision": self_collision_block,
          "contact": contact_block}


def fill(root):
    """Fills the blocks of every page in docs/."""
    root = pathlib.Path(root)
    for page in sorted((root / "docs").glob("*.md")):
        fill_page(page, root / "docs" / "bench")


def fill_page(page, bench):
    text = page.read_text()

    def replace(match):
        name = match.group(2)
        if name not in BLOCKS:
            raise SystemExit(f"performance_page.py: {page.name}: no block named '{name}'")
        try:
            body = BLOCKS[name](bench)
        except OSError as e:  # its command has not run here (or its files were removed)
            print(f"performance_page.py: {page.name}: block '{name}' not measured: {e}",
                  file=sys.stderr)
            how = NOT_MEASURED.get(name, "`bash scripts/bench.sh`")
            body = stamp_line(f"Not measured yet: {how} writes its files.")
        return match.group(1) + body + match.group(4)

    filled = BLOCK.sub(replace, text)
    if filled != text:
        page.write_text(filled)
    return filled


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--stamp":  # for the shell scripts
        print(stamp(sys.argv[2] if len(sys.argv) > 2 else "."))
        raise SystemExit(0)
    fill(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parent.parent)
