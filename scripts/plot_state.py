#!/usr/bin/python3
"""Plots fields of a simulator's ~state live, against sim time (rqt_plot's job; Debian 12 has no
rqt).

  plot_state.py FIELD [FIELD ...] [--node /simulator] [--window 20] [--output FILE --seconds S]

FIELD is a number field of constrained_particles/SimState: total_energy, energy_residual, energy_work_in,
energy_dissipated, max_position_error,
real_time_factor, accuracy_position_error, substeps, ... (`rosmsg show constrained_particles/SimState`).
Each gets its own axes. With a display, a window follows the last --window seconds of sim time;
with --output, it records --seconds of wall time and writes the plot to FILE (PNG, headless).
matplotlib draws it (Debian's python3-matplotlib).
"""
import argparse
import sys
import threading
import time

import rospy
from constrained_particles.msg import SimState


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("fields", nargs="+", metavar="FIELD")
    parser.add_argument("--node", default="/simulator")
    parser.add_argument("--window", type=float, default=20.0, help="sim seconds shown live")
    parser.add_argument("--output", help="write a PNG after --seconds instead of showing a window")
    parser.add_argument("--seconds", type=float, default=10.0, help="with --output: how long")
    args = parser.parse_args(rospy.myargv()[1:])
    numbers = {name for name, kind in zip(SimState.__slots__, SimState._slot_types)
               if kind in ("float64", "float32", "uint32", "uint64", "int32", "uint8")}
    for field in args.fields:
        if field not in numbers:
            sys.exit("plot_state.py: '%s' is not a number field of SimState; valid: %s"
                     % (field, ", ".join(sorted(numbers))))
    import matplotlib
    if args.output:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lock = threading.Lock()
    times, values = [], {field: [] for field in args.fields}

    def on_state(state):
        with lock:
            if times and state.sim_time < times[-1]:  # a reset: start over
                times.clear()
                for series in values.values():
                    series.clear()
            times.append(state.sim_time)
            for field in args.fields:
                values[field].append(float(getattr(state, field)))

    rospy.init_node("plot_state", anonymous=True)
    node = "/" + args.node.strip("/")
    rospy.Subscriber(node + "/state", SimState, on_state, queue_size=100)
    figure, axes = plt.subplots(len(args.fields), 1, sharex=True, squeeze=False,
                                figsize=(8, 2.2 * len(args.fields)))
    lines = {}
    for row, field in enumerate(args.fields):
        ax = axes[row][0]
        (lines[field],) = ax.plot([], [])
        ax.set_ylabel(field)
        ax.grid(True, alpha=0.3)
    axes[-1][0].set_xlabel("sim time [s]")
    figure.suptitle(node + "/state")

    def redraw():
        with lock:
            t = list(times)
            data = {field: list(series) for field, series in values.items()}
        if not t:
            return
        for row, field in enumerate(args.fields):
            lines[field].set_data(t, data[field])
            ax = axes[row][0]
            ax.relim()
            ax.autoscale_view()
            if not args.output:
                ax.set_xlim(max(t[0], t[-1] - args.window), max(t[-1], t[0] + 1e-9))

    if args.output:
        deadline = time.monotonic() + args.seconds
        while time.monotonic() < deadline and not rospy.is_shutdown():
            time.sleep(0.1)
        redraw()
        figure.tight_layout()
        figure.savefig(args.output, dpi=100)
        print("wrote %s (%d states)" % (args.output, len(times)))
        return
    plt.ion()
    plt.show()
    while plt.fignum_exists(figure.number) and not rospy.is_shutdown():
        redraw()
        figure.canvas.draw_idle()
        plt.pause(0.2)


if __name__ == "__main__":
    main()
