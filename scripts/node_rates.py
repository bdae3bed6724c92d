#!/usr/bin/python3
"""Runs the simulator node at several sizes, stepping as fast as the machine allows, and reports
per size the achieved real-time factor, steps/s, the /tf, ~state and ~particles rates and the
node's CPU use.

Starts its own roscore on a free port and a chain of N particles at real_time_factor 100 (the
largest allowed) per size; counts /tf, /simulator/state and /simulator/particles with rospy.AnyMsg
(no deserialising)
and reads sim time and steps from /diagnostics. Prints a markdown table of medians over --repeats
consecutive windows of --seconds each.
Usage: node_rates.py [--sizes N ...] [--seconds S] [--warmup S] [--repeats R] [--publish-rate HZ]
                     [--workspace DIR] [--start-timeout S] [--check-state-hz HZ]
                     [--check-particles-hz HZ] [--csv FILE]
With --csv FILE also writes the table there and its stamp (command, commit, date) beside it as
FILE with .stamp for .csv, which scripts/performance_page.py shows over it (docs/node.md).
Exit status: 0; 1 if --check-state-hz or --check-particles-hz failed; 2 if a node died or never published, or no
workspace or roscore.
"""
import argparse
import math
import os
import random
import shlex
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NODE_NAME = "simulator"
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000, 100000])
    p.add_argument("--seconds", type=float, default=10.0, help="measuring window [s]")
    p.add_argument("--warmup", type=float, default=3.0, help="after the first messages [s]")
    p.add_argument("--repeats", type=int, default=3, help="consecutive windows per size")
    p.add_argument("--publish-rate", type=float, default=None,
                   help="passed as _publish_rate:= (default: the node's own, 30 Hz)")
    p.add_argument("--workspace", default=os.path.join(ROOT, "build", "ws"))
    p.add_argument("--start-timeout", type=float, default=60.0,
                   help="wall seconds for a node's first /tf, ~state and /diagnostics")
    p.add_argument("--check-state-hz", type=float, default=None,
                   help="exit 1 if the largest size's ~state median is below this")
    p.add_argument("--csv", default=None, help="also write the table here (and its stamp)")
    p.add_argument("--check-particles-hz", type=float, default=None,
                   help="exit 1 if the largest size's ~particles median is below this")
    a = p.parse_args()
    if a.repeats < 1 or a.seconds <= 0 or a.warmup < 0 or any(n < 1 for n in a.sizes):
        p.error("--repeats, --seconds and --sizes must be positive, --warmup not negative")
    return a


def free_port():
    # outside the ephemeral range, so an outgoing connection cannot take it before roscore binds
    for port in random.sample(range(20000, 30000), 200):
        with socket.socket() as s:
            try:
                s.bind(("", port))
                return port
            except OSError:
                continue
    raise RuntimeError("no free TCP port in 20000-29999")


def workspace_env(workspace, master_uri):
    setup = os.path.join(workspace, "devel", "setup.bash")
    if not os.path.isfile(setup):
        raise RuntimeError(f"{setup} not found: build first (scripts/build.sh) or pass --workspace")
    out = subprocess.run(["bash", "-c", 'source "$1" && env -0', "_", setup],
                         check=True, stdout=subprocess.PIPE).stdout
    env = dict(item.split("=", 1) for item in out.decode().split("\0") if "=" in item)
    env["ROS_MASTER_URI"] = master_uri
    return env


def private_master(workspace, name):
    """A free port, its master URI, the workspace's environment for it and a log directory; this
    process's rospy pointed there, and SIGTERM and SIGHUP made Ctrl-C (the caller's finally
    stops what it started)."""
    port = free_port()
    master_uri = f"http://localhost:{port}"
    env = workspace_env(workspace, master_uri)
    log_dir = tempfile.mkdtemp(prefix=f"{name}.")
    env["ROS_LOG_DIR"] = log_dir
    # rospy in this process reads these at init_node
    os.environ["ROS_MASTER_URI"] = master_uri
    os.environ["ROS_LOG_DIR"] = log_dir
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, lambda s, _: sys.exit(128 + s))
    return port, master_uri, env, log_dir


def start_roscore(port, env, log_dir):
    """roscore on `port` in a session of its own (stop() ends it and what it started)."""
    with open(os.path.join(log_dir, "roscore.log"), "w") as log:
        return subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=log,
                                stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                start_new_session=True)


def wait_for_master(roscore, port, master_uri, log_dir, caller, timeout=30.0):
    """Returns once the master answers; RuntimeError if roscore died or `timeout` [s] passed."""
    import rosgraph
    master = rosgraph.Master(caller, master_uri=master_uri)
    deadline = time.monotonic() + timeout
    while not master.is_online():
        if roscore.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError(f"roscore on port {port} did not start:\n"
                               f"{tail(os.path.join(log_dir, 'roscore.log'))}")
        time.sleep(0.2)


def shut_down(roscore, log_dir, failed, name):
    """rospy down, roscore stopped; the logs kept only after a failure."""
    if "rospy" in sys.modules:
        sys.modules["rospy"].signal_shutdown(f"{name} done")
    stop(roscore)
    if failed:
        print(f"logs kept in {log_dir}", file=sys.stderr)
    else:
        shutil.rmtree(log_dir, ignore_errors=True)


def run(main, name, errors=(RuntimeError,)):
    """sys.exit(main()), with Ctrl-C as 130 and `errors` printed as exit 2."""
    try:
        sys.exit(main())
    except KeyboardInterrupt:
        sys.exit(130)
    except errors as e:
        print(f"{name}: {e}", file=sys.stderr)
        sys.exit(2)


def proc_stat(pid):
    """Fields of /proc/<pid>/stat after the command name (which may hold spaces), or None."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None


def cpu_seconds(pid):
    fields = proc_stat(pid)  # utime and stime are fields 14 and 15 of stat(5)
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS


def descendants(pid):
    """(pid, start time) of every process below pid, so a reused pid is never signalled."""
    children = {}
    for entry in os.listdir("/proc"):
        fields = proc_stat(entry) if entry.isdigit() else None
        if fields:
            children.setdefault(int(fields[1]), []).append((int(entry), fields[19]))
    found, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child[0])
    return found


def stop(proc, timeout=10.0):
    """SIGINT to the process group we started it in, SIGKILL if it lingers."""
    if proc is None or proc.poll() is not None:
        return
    # roscore puts rosmaster and rosout in groups of their own: remember them
    below = descendants(proc.pid)
    try:
        os.killpg(proc.pid, signal.SIGINT)
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    except ProcessLookupError:
        proc.wait()
    deadline = time.monotonic() + timeout
    for pid, start in below:
        while (fields := proc_stat(pid)) and fields[19] == start and fields[0] != "Z":
            if time.monotonic() > deadline:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                break
            time.sleep(0.1)


def tail(path, lines=20):
    try:
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-lines:])
    except OSError:
        return ""


class Counters:
    """Message counts and diagnostics samples, written from rospy's receive threads."""

    def __init__(self):
        self.lock = threading.Lock()
        self.tf = 0
        self.state = 0
        self.particles = 0
        self.diagnostics = []  # (receipt monotonic, stamp [s], sim_time [s], steps)

    def reset(self):
        with self.lock:
            self.tf = 0
            self.state = 0
            self.particles = 0
            self.diagnostics = []

    def on_tf(self, _):
        with self.lock:
            self.tf += 1

    def on_state(self, _):
        with self.lock:
            self.state += 1

    def on_particles(self, _):
        with self.lock:
            self.particles += 1

    def on_diagnostics(self, msg):
        now = time.monotonic()
        for status in msg.status:
            if status.name != f"/{NODE_NAME}: physics":
                continue
            values = {kv.key: kv.value for kv in status.values}
            try:
                sample = (now, msg.header.stamp.to_sec(), float(values["sim_time [s]"]),
                          int(values["steps"]))
            except (KeyError, ValueError):
                continue
            with self.lock:
                self.diagnostics.append(sample)

    def reset_counts(self):
        with self.lock:
            self.tf = 0
            self.state = 0
            self.particles = 0

    def snapshot(self):
        with self.lock:
            return self.tf, self.state, self.particles, list(self.diagnostics)


def measure_size(n, args, env, counters, log_dir):
    """One node, --repeats windows; returns (rows of per-window figures, error or None)."""
    node = os.path.join(args.workspace, "devel", "lib", "constrained_particles", "simulator_node")
    cmd = [node, f"__name:={NODE_NAME}", "_scenario:=chain", f"_chain/num_particles:={n}",
           f"_max_particles:={n}", "_real_time_factor:=100"]
    if args.publish_rate is not None:
        cmd.append(f"_publish_rate:={args.publish_rate:g}")
    log_path = os.path.join(log_dir, f"node_{n}.log")
    counters.reset()
    with open(log_path, "w") as log:
        proc = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + args.start_timeout
        while True:
            tf, state, particles, diags = counters.snapshot()
            if tf and state and particles and diags:
                break
            if proc.poll() is not None:
                return [], (f"node died before publishing (exit {proc.returncode}):\n"
                            f"{tail(log_path)}")
            if time.monotonic() > deadline:
                return [], (f"no /tf, ~state, ~particles and /diagnostics within "
                            f"{args.start_timeout:g} s (counts {tf}, {state}, {particles}, "
                            f"{len(diags)}):\n{tail(log_path)}")
            time.sleep(0.1)
        time.sleep(args.warmup)
        windows = []
        for _ in range(args.repeats):
            counters.reset_counts()
            t0, cpu0 = time.monotonic(), cpu_seconds(proc.pid)
            time.sleep(args.seconds)
            tf, state, particles, diags = counters.snapshot()
            t1, cpu1 = time.monotonic(), cpu_seconds(proc.pid)
            if proc.poll() is not None:
                return windows, (f"node died while measured (exit {proc.returncode}):\n"
                                 f"{tail(log_path)}")
            wall = t1 - t0
            rtf = steps_per_s = math.nan
            inside = [d for d in diags if t0 <= d[0] <= t1]
            before = [d for d in diags if d[0] < t0]
            # fewer than two samples inside (a node too busy for its 1 Hz timer): widen by one
            if len(inside) < 2 and before:
                inside.insert(0, before[-1])
            # sim time and steps over the node's own publish stamps (wall clock, no use_sim_time)
            if len(inside) >= 2 and inside[-1][1] > inside[0][1]:
                span = inside[-1][1] - inside[0][1]
                rtf = (inside[-1][2] - inside[0][2]) / span
                steps_per_s = (inside[-1][3] - inside[0][3]) / span
            windows.append({"steps/s": steps_per_s, "rtf": rtf, "tf": tf / wall,
                            "state": state / wall, "particles": particles / wall,
                            "cpu": 100.0 * (cpu1 - cpu0) / wall})
        return windows, None
    finally:
        stop(proc)


def median(values):
    values = [v for v in values if not math.isnan(v)]
    return statistics.median(values) if values else math.nan


def fmt(value, digits):
    return "n/a" if math.isnan(value) else f"{value:,.{digits}f}"


def fmt_sig(value):
    return "n/a" if math.isnan(value) else f"{value:.3g}"


def machine():
    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{model}, nproc {len(os.sched_getaffinity(0))}"


def main():
    args = parse_args()
    args.workspace = os.path.abspath(args.workspace)
    port, master_uri, env, log_dir = private_master(args.workspace, "node_rates")
    roscore = None
    failed = False
    try:
        roscore = start_roscore(port, env, log_dir)
        try:
            wait_for_master(roscore, port, master_uri, log_dir, "/node_rates")
        except RuntimeError as e:
            sys.stderr.write(f"{e}\n")
            failed = True
            return 2
        import rospy
        from diagnostic_msgs.msg import DiagnosticArray

        rospy.init_node("node_rates", anonymous=True, disable_signals=True)
        counters = Counters()
        # unbounded queues: rospy drops beyond queue_size per read, which would undercount
        rospy.Subscriber("/tf", rospy.AnyMsg, counters.on_tf, queue_size=None, buff_size=1 << 20)
        rospy.Subscriber(f"/{NODE_NAME}/state", rospy.AnyMsg, counters.on_state,
                         queue_size=None, buff_size=1 << 20)
        rospy.Subscriber(f"/{NODE_NAME}/particles", rospy.AnyMsg, counters.on_particles,
                         queue_size=None, buff_size=1 << 24)
        rospy.Subscriber("/diagnostics", DiagnosticArray, counters.on_diagnostics, queue_size=None)

        rows = []
        self_cpu = []
        for n in args.sizes:
            print(f"measuring {n:,} particles ...", file=sys.stderr, flush=True)
            t0, cpu0 = time.monotonic(), cpu_seconds(os.getpid())
            windows, error = measure_size(n, args, env, counters, log_dir)
            self_cpu.append(100.0 * (cpu_seconds(os.getpid()) - cpu0) / (time.monotonic() - t0))
            if error:
                failed = True
                print(f"{n:,} particles: {error}", file=sys.stderr)
            rows.append((n, {key: median([w[key] for w in windows])
                             for key in ("steps/s", "rtf", "tf", "state", "particles", "cpu")},
                         error))

        print("| particles | steps/s | real-time factor | /tf [Hz] | ~state [Hz] | ~particles [Hz] "
              "| node CPU [%] |")
        print("|---:|---:|---:|---:|---:|---:|---:|")
        for n, m, error in rows:
            if error and math.isnan(m["tf"]):
                reason = "node died" if "died" in error else "never published"
                print(f"| {n:,} | {reason} | | | | | |")
                continue
            died = " (node died later)" if error else ""
            print(f"| {n:,}{died} | {fmt(m['steps/s'], 0)} | {fmt_sig(m['rtf'])} "
                  f"| {fmt(m['tf'], 1)} | {fmt(m['state'], 1)} | {fmt(m['particles'], 1)} "
                  f"| {fmt(m['cpu'], 0)} |")
        asked = (f"{args.publish_rate:g} Hz" if args.publish_rate is not None
                 else "30 Hz (the node's default)")
        print(f"\nPublish rate asked: {asked}; real_time_factor 100 asked; medians of "
              f"{args.repeats} x {args.seconds:g} s after {args.warmup:g} s warm-up; "
              f"100 % CPU = one core; machine: {machine()}; "
              f"/tf carries at most 1,000 frames (~tf_frames -1); "
              f"measuring process CPU {fmt(max(self_cpu), 0)} % at most; "
              f"command: {shlex.join(['scripts/node_rates.py'] + sys.argv[1:])}")

        if args.csv and not failed:  # a size that failed: no table to stand for all
            # imported here: node_kernel_ratio.py imports this module, performance_page none
            from performance_page import write_measurement
            write_measurement(
                ROOT, args.csv, ["n", "steps_per_s", "real_time_factor", "tf_hz", "state_hz",
                                 "particles_hz", "node_cpu_percent"],
                [[n, f"{m['steps/s']:.1f}", f"{m['rtf']:.4g}", f"{m['tf']:.2f}",
                  f"{m['state']:.2f}", f"{m['particles']:.2f}", f"{m['cpu']:.1f}"]
                 for n, m, _ in rows],
                f"`{shlex.join(['scripts/node_rates.py'] + sys.argv[1:])}` (publish rate {asked}, "
                f"medians of {args.repeats} x {args.seconds:g} s)")

        largest = max(rows, key=lambda r: r[0])
        for topic, key, wanted in (("~state", "state", args.check_state_hz),
                                   ("~particles", "particles", args.check_particles_hz)):
            hz = largest[1][key]
            if wanted is not None and (math.isnan(hz) or hz < wanted):
                print(f"check failed: {topic} at {largest[0]:,} particles is {fmt(hz, 1)} Hz, "
                      f"below {wanted:g} Hz", file=sys.stderr)
                return 2 if failed else 1
        return 2 if failed else 0
    finally:
        shut_down(roscore, log_dir, failed, "node_rates")


if __name__ == "__main__":
    run(main, "node_rates")
