#!/usr/bin/python3
"""The node's own step cost against the minimum-work kernel (issue 33, item 7), in the same minutes.

For each size n, starts the simulator node on its own roscore with the peer chain (the `chain`
scene, n particles, links of 0.1 m, 0.1 kg, pinned, released along +x; rk4 + projection at
dt = 1 ms, every step check at the node's defaults), then --rounds times: reads ~state.step_time
(wall time per step over each batch, runner included; from /diagnostics, which carries it once a
second and costs the node nothing to read) for --seconds while the node steps, then runs the
kernel alone for --seconds (`bench_kernel --kernel-time n S`, bench/kernel_ratio.cpp, wall time
per step too) while the node is paused.
How the node steps (--drive): `step` (default) pauses it and asks ~step for steps in batches back
to back, which the runner takes chunk by chunk with its fault checks, pacing and snapshots: the
step's cost through the node, hot as the kernel's; `rate` lets it run at --real-time-factor,
where a small scene sleeps most of each millisecond between its batches and the wake-ups (cold
caches, a slower clock) show in its step time.
What the node is set against (--against): `kernel` (default) the minimum-work kernel; `engine`
the core's own step (Simulator::step, `bench_kernel --engine-time`) on the same chain at the
same settings, the node then run at max_substeps 1 and energy_budget 0 as the engine is: the
ratio is the runner's own work (issue 47); `checked` the core's step at the node's default step
settings (the stability estimate, sub-step retakes, the energy budget), the node at its defaults.
Prints per n the medians and the median of the rounds' ratios (node / kernel).
With --csv FILE also writes the table there and its stamp (command, commit, date) beside it as
FILE with .stamp for .csv, which scripts/performance_page.py shows over it.
Usage: node_kernel_ratio.py [--sizes N ...] [--seconds S] [--rounds R] [--warmup S]
                            [--real-time-factor F] [--workspace DIR] [--kernel PATH] [--csv FILE]
Exit status: 0; 2 if a node died or never published, or no workspace, kernel or roscore.
"""
import argparse
import os
import shlex
import statistics
import subprocess
import sys
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
# the roscore, workspace and process handling node_rates.py already does (one copy)
from node_rates import (machine, private_master, run, shut_down, start_roscore,  # noqa: E402
                        stop, tail, wait_for_master)
from performance_page import write_measurement  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NODE_NAME = "simulator"
MAX_STEPS_PER_CALL = 1000000  # limits::STEPS_PER_CALL's upper end


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[10, 100, 1000])
    p.add_argument("--seconds", type=float, default=5.0, help="each node and kernel window [s]")
    p.add_argument("--rounds", type=int, default=5, help="node/kernel window pairs per size")
    p.add_argument("--warmup", type=float, default=3.0, help="after the first ~state [s]")
    p.add_argument("--real-time-factor", type=float, default=100.0,
                   help="the node's ~real_time_factor (100, the largest, steps as fast as it can "
                        "at n = 1,000)")
    p.add_argument("--workspace", default=os.path.join(ROOT, "build", "ws"))
    p.add_argument("--kernel", default=None,
                   help="bench_kernel (default: the workspace's, built by scripts/bench.sh)")
    p.add_argument("--start-timeout", type=float, default=60.0)
    p.add_argument("--csv", default=None, help="also write the table here (and its stamp)")
    p.add_argument("--drive", choices=("step", "rate"), default="step",
                   help="step: paused, ~step back to back (default); rate: at --real-time-factor")
    p.add_argument("--against", choices=("kernel", "engine", "checked"), default="kernel",
                   help="kernel: the minimum-work kernel (default); engine: the core's step at "
                        "the same settings (the node at max_substeps 1, energy_budget 0); "
                        "checked: the core's step at the node's default settings")
    a = p.parse_args()
    if a.rounds < 1 or a.seconds <= 0 or any(n < 2 for n in a.sizes):
        p.error("--rounds and --seconds must be positive, --sizes at least 2")
    return a


class StepTimes:
    """~state.step_time as /diagnostics carries it (1 Hz, a few hundred bytes: reading ~state
    would deserialise every position 30 times a second beside the node being measured), from
    rospy's receive thread; only while the node runs (not paused or faulted)."""

    def __init__(self):
        self.lock = threading.Lock()
        self.values = []

    def on_diagnostics(self, msg):
        for status in msg.status:
            # paused and idle: no steps (a running ~step reads 'paused, running a ~step')
            if status.name != f"/{NODE_NAME}: physics" or status.message == "paused":
                continue
            values = {kv.key: kv.value for kv in status.values}
            try:
                step_time = float(values["step_time [s]"])
            except (KeyError, ValueError):
                continue
            if step_time > 0.0 and status.level < status.ERROR:
                with self.lock:
                    self.values.append(step_time)

    def take(self):
        with self.lock:
            values, self.values = self.values, []
            return values


def kernel_step_time(kernel, n, seconds, against):
    command = [kernel, "--kernel-time", str(n), f"{seconds:g}"]
    if against != "kernel":
        command = [kernel, "--engine-time", str(n), f"{seconds:g}"] + \
            (["checked"] if against == "checked" else [])
    out = subprocess.run(command, check=True, stdout=subprocess.PIPE, text=True).stdout
    # "kernel n = 10: 7.037068e-07 s/step (...)"
    return float(out.split(":", 1)[1].split()[0])


def measure_size(n, args, env, times, log_dir):
    import rospy
    from constrained_particles.srv import Reset, Step
    from std_srvs.srv import Empty

    node = os.path.join(args.workspace, "devel", "lib", "constrained_particles", "simulator_node")
    cmd = [node, f"__name:={NODE_NAME}", "_scenario:=chain", f"_chain/num_particles:={n}",
           "_chain/link_length:=0.1", "_chain/particle_mass:=0.1", f"_max_particles:={n}",
           f"_real_time_factor:={args.real_time_factor:g}", "_integrator:=rk4", "_stabilization:=projection",
           "_dt:=0.001", "_accuracy_window:=0"]
    if args.against == "engine":  # the engine's settings: the integrator alone, no budget
        cmd += ["_max_substeps:=1", "_energy_budget:=0"]
    log_path = os.path.join(log_dir, f"node_{n}.log")
    with open(log_path, "w") as log:
        proc = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + args.start_timeout
        while not times.take():
            if proc.poll() is not None:
                raise RuntimeError(f"node died (exit {proc.returncode}):\n{tail(log_path)}")
            if time.monotonic() > deadline:
                raise RuntimeError(f"no running ~state within {args.start_timeout:g} s:\n"
                                   f"{tail(log_path)}")
            time.sleep(0.1)
        pause = rospy.ServiceProxy(f"/{NODE_NAME}/pause", Empty)
        unpause = rospy.ServiceProxy(f"/{NODE_NAME}/unpause", Empty)
        step = rospy.ServiceProxy(f"/{NODE_NAME}/step", Step)
        reset = rospy.ServiceProxy(f"/{NODE_NAME}/reset", Reset)
        time.sleep(args.warmup)
        rounds = []
        for _ in range(args.rounds):
            stepping, done = None, threading.Event()
            if args.against != "kernel":
                # each round from rest, as the engine's own timing runs: the same stretch of
                # motion (a chain falling from rest needs more sub-steps as it speeds up, and at
                # max_substeps 1 it outgrows rk4's stability after ~12 s)
                pause()
                reset("")
            if args.drive == "step":
                pause()

                def step_until_done():
                    # one ~step answers when its steps are done or a ~pause stops it: asked
                    # again at once until the window ends (a small chain takes 10^6 in a second)
                    while not done.is_set():
                        step(MAX_STEPS_PER_CALL)

                stepping = threading.Thread(target=step_until_done, daemon=True)
                stepping.start()
            times.take()
            time.sleep(args.seconds)
            node_values = times.take()
            if proc.poll() is not None or not node_values:
                raise RuntimeError(f"node died or stopped publishing:\n{tail(log_path)}")
            done.set()
            pause()  # ends a running ~step at its next batch
            deadline = time.monotonic() + args.start_timeout
            # a ~step asked just before `done` is ended by the next pause
            while stepping and stepping.is_alive() and time.monotonic() < deadline:
                stepping.join(timeout=0.5)
                pause()
            try:
                kernel = kernel_step_time(args.kernel, n, args.seconds, args.against)
            except subprocess.CalledProcessError as e:
                raise RuntimeError(f"{args.kernel} failed (exit {e.returncode})")
            unpause()
            node_time = statistics.median(node_values)
            rounds.append((node_time, kernel, node_time / kernel))
        return rounds
    finally:
        stop(proc)


def write_csv(path, table, command, details):
    write_measurement(ROOT, path, ["n", "node_s_per_step", "kernel_s_per_step", "ratio_median",
                                   "ratio_min", "ratio_max"],
                      [[n, f"{node:.6e}", f"{kernel:.6e}", f"{median:.4f}", f"{low:.4f}",
                        f"{high:.4f}"] for n, node, kernel, median, low, high in table],
                      f"`{command}` ({details})")


def main():
    args = parse_args()
    args.workspace = os.path.abspath(args.workspace)
    if args.kernel is None:
        args.kernel = os.path.join(args.workspace, "devel", "lib", "constrained_particles",
                                   "bench_kernel")
    if not os.access(args.kernel, os.X_OK):
        raise RuntimeError(f"{args.kernel} not found: build it with CP_BUILD_BENCH=ON "
                           "(scripts/bench.sh --kernel does) or pass --kernel")
    port, master_uri, env, log_dir = private_master(args.workspace, "node_kernel_ratio")
    roscore = None
    failed = False
    try:
        roscore = start_roscore(port, env, log_dir)
        failed = True  # until the master answers: keep the logs
        wait_for_master(roscore, port, master_uri, log_dir, "/node_kernel_ratio")
        failed = False
        import rospy
        from diagnostic_msgs.msg import DiagnosticArray

        rospy.init_node("node_kernel_ratio", anonymous=True, disable_signals=True)
        times = StepTimes()
        rospy.Subscriber("/diagnostics", DiagnosticArray, times.on_diagnostics, queue_size=None)
        table = []
        print("| n | node step_time [us] | kernel [us] | node / kernel (median of rounds) "
              "| range |")
        print("|---:|---:|---:|---:|---|")
        for n in args.sizes:
            print(f"measuring n = {n:,} ...", file=sys.stderr, flush=True)
            try:
                rounds = measure_size(n, args, env, times, log_dir)
            except RuntimeError as e:
                failed = True
                print(f"n = {n}: {e}", file=sys.stderr)
                continue
            node = statistics.median(r[0] for r in rounds)
            kernel = statistics.median(r[1] for r in rounds)
            ratios = [r[2] for r in rounds]
            table.append((n, node, kernel, statistics.median(ratios), min(ratios), max(ratios)))
            print(f"| {n:,} | {node * 1e6:.3g} | {kernel * 1e6:.3g} | "
                  f"{statistics.median(ratios):.2f} | {min(ratios):.2f} to {max(ratios):.2f} |",
                  flush=True)
        command = shlex.join(['scripts/node_kernel_ratio.py'] + sys.argv[1:])
        print(f"\n{args.rounds} rounds of {args.seconds:g} s node, {args.seconds:g} s kernel per "
              f"size; machine: {machine()}; command: {command}")
        if args.csv and table and not failed:  # a size that failed: no table to stand for all
            write_csv(args.csv, table, command,
                      f"{args.rounds} rounds of {args.seconds:g} s, node driven by {args.drive}, "
                      f"against the {args.against}")
        return 2 if failed else 0
    finally:
        shut_down(roscore, log_dir, failed, "node_kernel_ratio")


if __name__ == "__main__":
    run(main, "node_kernel_ratio")
