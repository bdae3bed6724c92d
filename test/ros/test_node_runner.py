#!/usr/bin/python3
"""The node's runner seen from outside: a long ~step runs in batches while /tf and /diagnostics
keep coming, a ~pause stops it at the next batch, Ctrl-C stops the node within a second even
mid-step, ~state carries the core's reports for every step, and ~set_chain keeps the pin unless
told. Waits are wall-clock deadlines with polling."""
import os
import signal
import subprocess
import threading
import time
import unittest

import rospy
import rostest
from wall_clock import WallClockWaits
from constrained_particles.msg import SimState
from constrained_particles.srv import Reset, SetChain, SetChainRequest, Step
from diagnostic_msgs.msg import DiagnosticArray
from dynamic_reconfigure.client import Client
from std_srvs.srv import Empty

NODE = "/simulator"
PUBLISH_RATE = 30.0  # as node_runner.test sets it


class Counter:
    def __init__(self):
        self.lock = threading.Lock()
        self.count = 0

    def __call__(self, _message):
        with self.lock:
            self.count += 1

    def value(self):
        with self.lock:
            return self.count


class NodeRunnerTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("node_runner_test")
        for name in ("pause", "unpause", "step", "set_chain", "reset"):
            rospy.wait_for_service(f"{NODE}/{name}", timeout=60.0)
        cls.pause = rospy.ServiceProxy(f"{NODE}/pause", Empty)
        cls.unpause = rospy.ServiceProxy(f"{NODE}/unpause", Empty)
        cls.step = rospy.ServiceProxy(f"{NODE}/step", Step)
        cls.set_chain = rospy.ServiceProxy(f"{NODE}/set_chain", SetChain)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        cls.lock = threading.Lock()
        cls.states = []
        rospy.Subscriber(f"{NODE}/state", SimState, cls.store_state, queue_size=100)

    @classmethod
    def store_state(cls, message):
        with cls.lock:
            cls.states.append(message)
            del cls.states[:-300]

    def latest(self):
        with self.lock:
            return self.states[-1] if self.states else None


    def chain(self, n, pin=SetChainRequest.PIN_FIRST_KEEP):
        reply = self.set_chain(num_particles=n, link_length=0.5, particle_mass=1.0, pin_first=pin)
        self.assertTrue(reply.success, reply.message)
        self.wait_until(lambda: self.latest() is not None and len(self.latest().positions) == n,
                        f"~state with {n} particles")

    def test_long_step_keeps_publishing_and_pause_stops_it(self):
        self.chain(2000, SetChainRequest.PIN_FIRST_PIN)
        self.pause()
        tf_count, diagnostics_count = Counter(), Counter()
        tf = rospy.Subscriber("/tf", rospy.AnyMsg, tf_count, queue_size=100)
        diagnostics = rospy.Subscriber("/diagnostics", DiagnosticArray, diagnostics_count)
        result = {}
        worker = threading.Thread(target=lambda: result.setdefault("reply", self.step(1000000)))
        worker.start()
        try:
            self.wait_until(lambda: self.latest().steps > 0 and
                            self.latest().status == SimState.STATUS_PAUSED, "steps from ~step")
            start_steps = self.latest().steps
            # a window of wall time while the step runs: tf at its rate, diagnostics at 1 Hz
            tf_start, diagnostics_start, wall_start = tf_count.value(), diagnostics_count.value(), \
                time.monotonic()
            time.sleep(4.0)
            tf_rate = (tf_count.value() - tf_start) / (time.monotonic() - wall_start)
            diagnostics_seen = diagnostics_count.value() - diagnostics_start
            self.assertTrue(worker.is_alive(), "the step should still be running")
            self.assertGreater(self.latest().steps, start_steps, "~state frozen during ~step")
            self.assertEqual(self.latest().status_message, "paused, running a ~step")
            self.assertGreaterEqual(tf_rate, 0.8 * PUBLISH_RATE)
            self.assertGreaterEqual(diagnostics_seen, 2)
        finally:
            self.pause()
            worker.join(timeout=60.0)
            tf.unregister()
            diagnostics.unregister()
        self.assertFalse(worker.is_alive(), "~step did not return after ~pause")
        reply = result["reply"]
        self.assertFalse(reply.success)
        self.assertIn("~pause", reply.message)
        self.assertGreater(reply.steps_taken, 0)
        self.assertLess(reply.steps_taken, 1000000)
        self.wait_until(lambda: abs(self.latest().sim_time - reply.sim_time) < 1e-9,
                        f"~state at the step's end, t = {reply.sim_time} s")
        self.assertTrue(self.reset("").success)

    def test_waiting_service_calls_do_not_hold_up_publishing(self):
        # steps of seconds each (dopri5 at its tightest tolerance, dt = 1 s): every request waits
        self.chain(1000, SetChainRequest.PIN_FIRST_PIN)
        client = Client(NODE, timeout=60.0)
        client.update_configuration({"integrator": "dopri5", "adaptive_tolerance": 1e-14,
                                     "dt": 1.0})
        self.unpause()
        # the publishing thread's own timer: /diagnostics once a second (a state that took
        # seconds to step is not sent again under a new stamp, so /tf and ~state wait for it)
        stamps = []
        diagnostics = rospy.Subscriber("/diagnostics", rospy.AnyMsg,
                                       lambda _m: stamps.append(time.monotonic()), queue_size=100)
        # more callers than the node has service threads, all waiting for the step under way
        callers = [threading.Thread(target=self.pause) for _ in range(8)]
        try:
            self.wait_until(lambda: len(stamps) > 1, "/diagnostics before the calls")
            start = time.monotonic()
            for caller in callers:
                caller.start()
            time.sleep(4.0)  # the window observed
            window = [t for t in stamps if t >= start]
            gaps = [b - a for a, b in zip(window, window[1:])]
            self.assertGreaterEqual(len(window), 3)
            # 1 Hz asked: a gap of two seconds means publishing waited for the runner
            self.assertLess(max(gaps), 2.0)
        finally:
            for caller in callers:
                caller.join(timeout=120.0)
            diagnostics.unregister()
            client.update_configuration({"integrator": "rk4", "adaptive_tolerance": 1e-8,
                                         "dt": 0.001})
        self.assertFalse(any(caller.is_alive() for caller in callers))

    def test_state_reports_every_step_of_the_core(self):
        self.chain(5, SetChainRequest.PIN_FIRST_PIN)
        self.unpause()
        with self.lock:
            del self.states[:]
        self.wait_until(lambda: len(self.states) >= 30, "30 ~state messages")
        with self.lock:
            states = list(self.states)
        # interval statistics: every step counted once, none skipped between messages
        for previous, current in zip(states, states[1:]):
            if current.steps >= previous.steps and current.status == SimState.STATUS_RUNNING:
                self.assertEqual(current.interval_steps, current.steps - previous.steps)
        moved = [s for s in states[1:] if s.interval_steps > 0]
        self.assertTrue(moved)
        self.assertGreater(sum(s.reused_factorizations for s in moved), 0)
        for s in moved:
            self.assertGreater(s.factorizations, 0)
            self.assertEqual(s.singular_solves, 0)
            self.assertGreater(s.min_pivot_ratio, 0.0)
            self.assertTrue(s.projections_converged)
            self.assertEqual(s.projections, s.interval_steps)  # rk4 + projection: one per step
            # a fused chain's step reuses its last projection's factorisation at most once
            self.assertLessEqual(s.reused_factorizations, s.interval_steps)
            counts = dict(zip(s.effect_names, s.effect_counts))
            self.assertIn("gravity", counts)
            self.assertIn("link", counts)
            self.assertAlmostEqual(s.total_energy, s.kinetic_energy + s.potential_energy, places=9)

    def test_set_chain_keeps_the_pin_unless_told(self):
        self.unpause()
        self.chain(5, SetChainRequest.PIN_FIRST_PIN)
        # keep (the message default): still pinned, particle 0 stays at the origin
        self.chain(6)
        start = self.latest().sim_time
        self.wait_until(lambda: self.latest().sim_time > start + 0.5, "0.5 s of sim time")
        p = self.latest().positions[0]
        self.assertLess(abs(p.x) + abs(p.y) + abs(p.z), 1e-9)
        self.chain(6, SetChainRequest.PIN_FIRST_UNPIN)
        start = self.latest().sim_time
        self.wait_until(lambda: self.latest().sim_time > start + 0.5, "0.5 s of sim time")
        p = self.latest().positions[0]
        self.assertGreater(abs(p.x) + abs(p.y) + abs(p.z), 1e-3)
        reply = self.set_chain(num_particles=6, link_length=0.5, particle_mass=1.0, pin_first=3)
        self.assertFalse(reply.success)
        self.assertIn("pin_first", reply.message)
        self.chain(5, SetChainRequest.PIN_FIRST_PIN)

    def test_ctrl_c_stops_the_node_mid_step(self):
        name = "ctrl_c_simulator"
        node = subprocess.Popen(
            ["rosrun", "constrained_particles", "simulator_node", f"__name:={name}",
             "_scenario:=chain", "_chain/num_particles:=2000"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        try:
            rospy.wait_for_service(f"/{name}/step", timeout=60.0)
            rospy.ServiceProxy(f"/{name}/pause", Empty)()
            step = rospy.ServiceProxy(f"/{name}/step", Step)
            threading.Thread(target=lambda: self.call_quietly(step, 1000000), daemon=True).start()
            states = []
            sub = rospy.Subscriber(f"/{name}/state", SimState, states.append, queue_size=1)
            # paused, and still stepping: the ~step is under way (its service call in flight)
            self.wait_until(lambda: len(states) >= 2 and
                            states[-1].status == SimState.STATUS_PAUSED and
                            states[-2].status == SimState.STATUS_PAUSED and
                            states[-1].steps > states[-2].steps, "the step under way")
            sub.unregister()
            started = time.monotonic()
            # rosrun execs the node: the process we started is the node itself
            os.kill(node.pid, signal.SIGINT)
            node.wait(timeout=30.0)
            stopped_in = time.monotonic() - started
            # the node's own bound is 0.5 s; the margin is for a loaded machine
            self.assertLess(stopped_in, 1.0)
        finally:
            if node.poll() is None:
                node.kill()
                node.wait()

    @staticmethod
    def call_quietly(service, steps):
        try:
            service(steps)
        except rospy.ServiceException:
            pass  # the node went away mid-call: what this test does on purpose


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "node_runner", NodeRunnerTest)
