#!/usr/bin/python3
"""~follow_clock: the node (chain, dt = 1 ms) steps up to each /clock and never past it."""
import random
import subprocess
import time
import unittest

import rospy
import rostest
from constrained_particles.msg import SimState
from constrained_particles.srv import Step
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Empty
from topic_recorder import Recorder
from wall_clock import WallClockWaits

NODE = "/simulator"
START_NS = 1_733_000_000_123_000_000  # the first clock, near the epoch as a bag's (ns)
DT_NS = 1_000_000  # dt = 1 ms


def clock_of(ns):
    msg = Clock()
    msg.clock = rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000)
    return msg


class FollowClockTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("follow_clock_test")
        rospy.wait_for_service(f"{NODE}/step", timeout=60.0)
        cls.step = rospy.ServiceProxy(f"{NODE}/step", Step)
        cls.pause = rospy.ServiceProxy(f"{NODE}/pause", Empty)
        cls.states = Recorder(f"{NODE}/state", SimState, keep=5000)
        cls.diagnostics = Recorder("/diagnostics", DiagnosticArray, keep=20)
        cls.wrench = Recorder(f"{NODE}/anchor_wrench/particle_0", WrenchStamped, keep=100)
        cls.clock = rospy.Publisher("/clock", Clock, queue_size=100)

    def test_steps_up_to_each_clock_and_never_past_it(self):
        # no /clock yet: no state goes out, and /diagnostics says why
        started = time.monotonic()
        status = self.wait_until(
            lambda: next((s for a in self.diagnostics.since(started) for s in a.status
                          if "~follow_clock" in s.message), None), "the wait in /diagnostics")
        self.assertEqual(status.level, DiagnosticStatus.WARN)
        self.assertEqual(self.states.since(0.0), [])
        # the first clock, sent once both subscribers are connected (this process's own /clock
        # subscription and the node's): sim time 0 stands for it, and its state and its pin's
        # wrench go out (the first clock's state used to wait for the rate window's snapshot)
        self.wait_until(lambda: self.clock.get_num_connections() >= 2, "the node subscribing")
        self.wait_until(lambda: self.wrench.subscriber.get_num_connections() > 0,
                        "the wrench topic connected")
        self.clock.publish(clock_of(START_NS))
        first = self.wait_until(self.states.latest, "a state stamped with the first clock", 30.0)
        self.assertEqual(first.steps, 0)
        self.assertEqual(first.header.stamp, clock_of(START_NS).clock)
        wrench = self.wait_until(self.wrench.latest, "the pin's wrench at the first clock", 30.0)
        self.assertEqual(wrench.header.stamp, clock_of(START_NS).clock)
        # irregular increments of whole steps (each ends exactly on a step: floor() at its edge),
        # and after each clock the scene has taken floor((c - c0) / dt) steps, never more
        rng = random.Random(37)
        now_ns = START_NS
        sent = [(0.0, START_NS)]  # (wall time sent, clock [ns]): the first went before any state
        for k in range(40):
            now_ns += DT_NS * rng.choice([0, 1, 2, 7, 13, 50, 150]) + (DT_NS // 2 if k == 20 else 0)
            self.clock.publish(clock_of(now_ns))
            sent.append((time.monotonic(), now_ns))
            expected = (now_ns - START_NS) // DT_NS
            # states only ever step forward: the newest shows whether it got there
            self.wait_until(lambda: self.states.latest().steps >= expected,
                            f"{expected} steps after clock {k}", 30.0, poll=0.005)
            self.assertEqual(self.states.latest().steps, expected, f"clock {k}")
        # held still, the clock holds the scene: no step past it
        time.sleep(1.0)
        self.assertEqual(self.states.latest().steps, expected)
        # never ahead: each state stands for a clock sent before it arrived (its stamp), and
        # its step count is that clock's floor
        for arrived, state in list(self.states.items):
            clock_ns = max(c for t, c in sent if t <= arrived)
            self.assertLessEqual(state.steps, (clock_ns - START_NS) // DT_NS)
            self.assertLessEqual(state.header.stamp.to_nsec(), clock_ns)
            self.assertEqual(state.header.stamp.to_nsec(), START_NS + state.steps * DT_NS)
        # ~step would run ahead of the clock
        self.pause()
        reply = self.step(10)
        self.assertFalse(reply.success)
        self.assertIn("~follow_clock", reply.message)

    def test_refused_combinations_stop_a_node_at_start(self):
        run = subprocess.run(
            ["rosrun", "constrained_particles", "simulator_node", "__name:=both",
             "_follow_clock:=true", "_publish_clock:=true"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
        self.assertNotEqual(run.returncode, 0, run.stdout)
        self.assertIn("~follow_clock", run.stdout)
        self.assertIn("~publish_clock", run.stdout)
        # without /use_sim_time (read once at start: the running node keeps its own)
        rospy.set_param("/use_sim_time", False)
        try:
            run = subprocess.run(
                ["rosrun", "constrained_particles", "simulator_node", "__name:=wall",
                 "_follow_clock:=true"],
                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
        finally:
            rospy.set_param("/use_sim_time", True)
        self.assertNotEqual(run.returncode, 0, run.stdout)
        self.assertIn("~follow_clock", run.stdout)
        self.assertIn("/use_sim_time", run.stdout)


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "follow_clock", FollowClockTest)
