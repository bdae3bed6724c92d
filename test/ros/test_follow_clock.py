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
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Empty
from topic_recorder import Recorder
from wall_clock import WallClockWaits

NODE = "/simulator"
START_US = 100_000_000  # the first clock: 100 s, in microseconds
DT_US = 1000


def clock_of(us):
    msg = Clock()
    msg.clock = rospy.Time(us // 1_000_000, (us % 1_000_000) * 1000)
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
        cls.clock = rospy.Publisher("/clock", Clock, queue_size=100)

    def test_steps_up_to_each_clock_and_never_past_it(self):
        # no /clock yet: no state goes out, and /diagnostics says why
        started = time.monotonic()
        status = self.wait_until(
            lambda: next((s for a in self.diagnostics.since(started) for s in a.status
                          if "~follow_clock" in s.message), None), "the wait in /diagnostics")
        self.assertEqual(status.level, DiagnosticStatus.WARN)
        self.assertEqual(self.states.since(0.0), [])
        # the first clock (sent until the node shows it): sim time 0 stands for 100 s
        self.wait_until(lambda: self.clock.get_num_connections() > 0, "the node subscribing")
        first = self.wait_until(
            lambda: (self.clock.publish(clock_of(START_US)), self.states.latest())[1],
            "a state stamped with the first clock", poll=0.05)
        self.assertEqual(first.steps, 0)
        self.assertEqual(first.header.stamp, clock_of(START_US).clock)
        # irregular increments, each 0.4 ms past a step's end so that floor() is unambiguous
        rng = random.Random(37)
        now_us = START_US + 400
        sent = []  # (wall time sent, clock [us])
        for _ in range(60):
            now_us += DT_US * rng.choice([0, 1, 2, 7, 13, 50, 150])
            self.clock.publish(clock_of(now_us))
            sent.append((time.monotonic(), now_us))
            time.sleep(rng.uniform(0.005, 0.1))
        expected = (now_us - START_US) // DT_US
        last = self.wait_until(
            lambda: next((s for s in reversed(self.states.since(sent[-1][0]))
                          if s.steps == expected), None), f"{expected} steps", 30.0)
        self.assertAlmostEqual(last.sim_time, expected * 1e-3, delta=1e-9)
        # held still, the clock holds the scene: no step past it
        time.sleep(1.0)
        self.assertEqual(self.states.latest().steps, expected)
        # never ahead: each state's time is within the newest clock sent before it arrived, and
        # its stamp is the clock time it stands for
        for arrived, state in [(t, s) for t, s in self.states.items]:
            clock_us = max([c for t, c in sent if t <= arrived] + [START_US])
            self.assertLessEqual(state.sim_time, (clock_us - START_US) * 1e-6 + 1e-9, state.steps)
            self.assertAlmostEqual(state.header.stamp.to_sec(), START_US * 1e-6 + state.sim_time,
                                   delta=2e-9 * START_US * 1e-6)
        # ~step would run ahead of the clock
        self.pause()
        reply = self.step(10)
        self.assertFalse(reply.success)
        self.assertIn("~follow_clock", reply.message)

    def test_a_node_that_follows_and_publishes_the_clock_is_refused_at_start(self):
        run = subprocess.run(
            ["rosrun", "constrained_particles", "simulator_node", "__name:=both",
             "_follow_clock:=true", "_publish_clock:=true"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
        self.assertNotEqual(run.returncode, 0, run.stdout)
        self.assertIn("~follow_clock", run.stdout)


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "follow_clock", FollowClockTest)
