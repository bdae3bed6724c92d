#!/usr/bin/env python3
"""Asks running simulators what accuracy costs on their scene (the ~compare_methods action).

  compare_methods.py [--node /simulator ...] [--horizon S] [--target M] [--from-current]
                     [--method INTEGRATOR[:STABILIZATION]:DT[:TOLERANCE] ...] [--output DIR]

With one --node, that node runs the whole study (and with --output writes its CSV and diagram
there, on its own machine). With several (e.g. launch/compare_fleet.launch, possibly on other
machines joined to the same master through roslaunch <machine> tags), the study is split: node k
of K runs methods k, k + K, ... (the goal's part/parts), and this script merges their tables,
picks the recommendation over all of them and, with --output, writes the merged CSV and diagram
here. CPU times from different machines are only comparable if the machines are alike.
Progress goes to stderr as a bar; the table to stdout. Exit status 1 if a goal is rejected or
aborted (the reason is printed), 2 on a timeout.
"""
import argparse
import math
import os
import sys
import time

import actionlib
import rospy
from actionlib_msgs.msg import GoalStatus
from constrained_particles.msg import (CompareMethodsAction, CompareMethodsGoal, Method)

HERE = os.path.dirname(os.path.abspath(__file__))
CSV_HEADER = ("integrator,stabilization,dt_s,tolerance,position_error_m,reference_error_m,"
              "max_constraint_error_m,energy_drift_J,cpu_s_per_sim_s,steps,substeps,finite,"
              "recommended,error_target_m,horizon_s,failure")


def parse_method(text):
    """integrator[:stabilization]:dt[:tolerance] -> Method."""
    parts = text.split(":")
    m = Method()
    m.integrator = parts[0]
    try:
        if len(parts) == 2:
            m.dt = float(parts[1])
        elif len(parts) in (3, 4):
            m.stabilization = parts[1]
            m.dt = float(parts[2])
            if len(parts) == 4:
                m.tolerance = float(parts[3])
        else:
            raise ValueError
    except ValueError:
        sys.exit("--method %r: expected INTEGRATOR[:STABILIZATION]:DT[:TOLERANCE]" % text)
    return m


def label(method):
    if method.integrator in ("velocity_verlet", "fast_projection"):
        text = method.integrator + " (projects itself)"
    else:
        text = method.integrator + " + " + method.stabilization
    text += ", dt %g" % method.dt
    if method.integrator == "dopri5":
        text += ", tol %g" % method.tolerance
    return text


def recommend(runs, target, reference_error):
    """Index of the cheapest finite run within target (resolved by the reference), or -1."""
    if not target > reference_error:
        return -1
    best = -1
    for k, r in enumerate(runs):
        if r.finite and r.position_error <= target and (
                best < 0 or r.cpu_time_per_sim_second < runs[best].cpu_time_per_sim_second):
            best = k
    return best


def csv_text(runs, recommended, reference_error, target, horizon):
    lines = [CSV_HEADER]
    for k, r in enumerate(runs):
        m = r.method
        lines.append(",".join(str(v) for v in (
            m.integrator, m.stabilization, "%g" % m.dt, "%g" % m.tolerance,
            "%.6g" % r.position_error, "%.6g" % reference_error, "%.6g" % r.max_constraint_error,
            "%.6g" % r.energy_drift, "%.6g" % r.cpu_time_per_sim_second, r.steps, r.substeps,
            1 if r.finite else 0, 1 if k == recommended else 0, "%g" % target, "%g" % horizon,
            r.failure.replace(",", ";"))))
    return "\n".join(lines) + "\n"


def progress_bar(done, total, current, width=30):
    filled = int(width * done / total) if total else 0
    sys.stderr.write("\r[%s%s] %d/%d %-60.60s" % ("#" * filled, "." * (width - filled), done, total,
                                                  current))
    sys.stderr.flush()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog=__doc__)
    parser.add_argument("--node", action="append", help="simulator node (default /simulator)")
    parser.add_argument("--horizon", type=float, default=0.0, help="[s], 0 = 1 s")
    parser.add_argument("--target", type=float, default=0.0, help="error target [m], 0 = 1e-6")
    parser.add_argument("--from-current", action="store_true",
                        help="from the live state (default: the scene's start)")
    parser.add_argument("--method", action="append", default=[],
                        help="INTEGRATOR[:STABILIZATION]:DT[:TOLERANCE]; default: the node's set")
    parser.add_argument("--output", default="", help="directory for the CSV and the diagram")
    parser.add_argument("--timeout", type=float, default=3600.0, help="wall seconds to wait")
    args = parser.parse_args(rospy.myargv()[1:])
    nodes = args.node or ["/simulator"]
    rospy.init_node("compare_methods", anonymous=True, disable_signals=True)

    clients, progress = [], {}
    for k, node in enumerate(nodes):
        client = actionlib.SimpleActionClient(node.rstrip("/") + "/compare_methods",
                                              CompareMethodsAction)
        if not client.wait_for_server(rospy.Duration(30.0)):
            sys.exit("%s/compare_methods: no action server within 30 s" % node)
        goal = CompareMethodsGoal()
        goal.horizon = args.horizon
        goal.error_target = args.target
        goal.from_current_state = args.from_current
        goal.methods = [parse_method(text) for text in args.method]
        goal.part, goal.parts = k, len(nodes)
        # one node: it writes the files; several: this script writes the merged ones
        goal.output_directory = os.path.abspath(args.output) if args.output and len(nodes) == 1 \
            else ""

        def feedback(msg, node=node):
            progress[node] = (msg.done, msg.total, msg.current)
            done = sum(p[0] for p in progress.values())
            total = sum(p[1] for p in progress.values())
            progress_bar(done, total, msg.current)

        client.send_goal(goal, feedback_cb=feedback)
        clients.append((node, client))

    deadline = time.monotonic() + args.timeout
    for node, client in clients:
        while not client.wait_for_result(rospy.Duration(0.2)):
            if time.monotonic() > deadline or rospy.is_shutdown():
                for _, c in clients:
                    c.cancel_goal()
                sys.stderr.write("\n")
                sys.exit(2)
    sys.stderr.write("\n")

    runs, reference_error, results = [], 0.0, []
    for node, client in clients:
        state, result = client.get_state(), client.get_result()
        if state != GoalStatus.SUCCEEDED or result is None:
            sys.exit("%s: %s: %s" % (node, GoalStatus.to_string(state) if hasattr(
                GoalStatus, "to_string") else state, client.get_goal_status_text()))
        results.append(result)
        runs.extend(result.runs)
        reference_error = max(reference_error, result.reference_error)
    target, horizon = results[0].error_target, results[0].horizon
    scenario = results[0].scenario
    if any(r.scenario != scenario for r in results):
        sys.exit("the nodes run different scenes: %s" % ", ".join(r.scenario for r in results))
    recommended = recommend(runs, target, reference_error)

    print("scene %s, horizon %g s from t = %g s, reference error %.2g m, target %.3g m" % (
        scenario, horizon, results[0].start_time, reference_error, target))
    print("%-44s %12s %12s %12s %12s %8s" % ("method", "error [m]", "constr. [m]", "drift [J]",
                                             "CPU s/sim s", "substeps"))
    for k, r in enumerate(runs):
        print("%-44s %12.3e %12.3e %12.3e %12.3e %8d%s%s" % (
            label(r.method), r.position_error, r.max_constraint_error, r.energy_drift,
            r.cpu_time_per_sim_second, r.substeps, "  <- recommended" if k == recommended else "",
            "" if r.finite else "  (%s)" % (r.failure or "not finite")))
    if recommended >= 0:
        print("recommended for %.3g m: %s" % (target, label(runs[recommended].method)))
    else:
        print("no run met %.3g m" % target)

    if args.output:
        if len(clients) == 1:
            for path in (results[0].csv_path, results[0].diagram_path):
                if path:
                    print("wrote %s (on the node's machine)" % path)
            if not results[0].diagram_path:
                print("no diagram: %s" % results[0].message)
        else:
            os.makedirs(args.output, exist_ok=True)
            base = os.path.join(args.output, scenario + "_compare_methods")
            with open(base + ".csv", "w") as f:
                f.write(csv_text(runs, recommended, reference_error, target, horizon))
            sys.path.insert(0, HERE)
            import plot_compare_methods
            plot_compare_methods.draw(plot_compare_methods.read_runs(base + ".csv"),
                                      base + ".png", scenario + " (%d nodes)" % len(clients))
            print("wrote %s.csv and %s.png" % (base, base))


if __name__ == "__main__":
    main()
