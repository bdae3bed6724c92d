#!/usr/bin/python3
"""frame_anchor through the node: the rope's first particle follows tf frame 'hand' exactly, at
the hand's pose at every stamp (the node runs ~anchor_lag behind the clock); a frame not yet in
tf holds it where it is, with a WARN."""
import math
import time
import unittest

import rospy
import rostest
import tf2_ros
from constrained_particles.msg import SimState
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import TransformStamped, WrenchStamped
from rosgraph_msgs.msg import Clock
from topic_recorder import Recorder
from wall_clock import WallClockWaits

NODE = "/simulator"
START_NS = 1_733_000_000_000_000_000  # the first clock, a multiple of the 10 ms tick (ns)
TICK_NS = 10_000_000  # /clock and the frame advance in 10 ms ticks
LAG = 0.3  # ~anchor_lag [s]: fixed here (generous: the broadcasts may arrive late on a busy machine)
LINK = 0.12  # hold_the_rope's links [m]
START = (0.0, 0.0, 1.5)  # where the rope's first particle starts [m]


def hand(ns):
    """The frame's origin at ROS time ns: a horizontal circle of 0.2 m at 0.5 Hz about the start."""
    angle = 2.0 * math.pi * 0.5 * (ns - START_NS) * 1e-9
    return (0.2 * math.sin(angle), 0.2 * (1.0 - math.cos(angle)), 1.5)


def stamp_of(ns):
    return rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000)


class FrameAnchorTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("frame_anchor_test")
        cls.states = Recorder(f"{NODE}/state", SimState, keep=5000)
        cls.diagnostics = Recorder("/diagnostics", DiagnosticArray, keep=20)
        cls.wrenches = Recorder(f"{NODE}/anchor_wrench/particle_0", WrenchStamped, keep=100)
        cls.clock = rospy.Publisher("/clock", Clock, queue_size=100)
        cls.tf = tf2_ros.TransformBroadcaster()

    def tick(self, ns, broadcast):
        if broadcast:
            t = TransformStamped()
            t.header.stamp = stamp_of(ns)
            t.header.frame_id = "world"
            t.child_frame_id = "hand"
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = hand(ns)
            # turned 90 degrees about z: the anchor wrench comes in the hand's axes
            t.transform.rotation.z = math.sqrt(0.5)
            t.transform.rotation.w = math.sqrt(0.5)
            self.tf.sendTransform(t)
        msg = Clock()
        msg.clock = stamp_of(ns)
        self.clock.publish(msg)

    def test_held_particle_follows_the_frame_exactly(self):
        self.wait_until(lambda: self.clock.get_num_connections() > 0, "the node subscribing")
        # 1 s of clock without the frame: the particle rests where it starts, and /diagnostics
        # warns naming the frame
        now = START_NS
        started = time.monotonic()
        for _ in range(100):
            self.tick(now, broadcast=False)
            now += TICK_NS
            time.sleep(0.01)
        status = self.wait_until(
            lambda: next((s for a in self.diagnostics.since(started) for s in a.status
                          if "frame hand" in s.message), None), "a WARN naming frame 'hand'",
            poll=0.05)
        self.assertEqual(status.level, DiagnosticStatus.WARN)
        resting = self.wait_until(self.states.latest, "a state")
        self.assertEqual(list(resting.held_particles), [0])
        self.assertEqual(list(resting.holders), ["hand"])
        self.assertAlmostEqual(resting.anchor_lag, LAG)
        p = resting.positions[0]
        self.assertLess(math.dist((p.x, p.y, p.z), START), 1e-12)
        # the frame moves on its circle, one pose per tick, the clock a tick after; 6 s of it
        first_broadcast = now
        for _ in range(600):
            self.tick(now, broadcast=True)
            now += TICK_NS
            time.sleep(0.01)
        last = now - TICK_NS
        # the state stamped `last` - LAG: the node runs the lag behind the clock, never ahead
        wanted = stamp_of(last - int(LAG * 1e9))
        self.wait_until(lambda: (self.tick(last, broadcast=False), self.states.latest())[1]
                        .header.stamp == wanted, "the state the lag behind the last clock",
                        poll=0.05)
        # every state stamped T, once T is after the frame's first broadcast plus two ticks (the
        # spline's first interval sets off from rest): the frame's pose at T itself
        checked = 0
        worst = 0.0
        worst_link = 0.0
        for state in self.states.since(started):
            t_ns = state.header.stamp.to_nsec()
            self.assertLessEqual(t_ns, last - int(LAG * 1e9), "a state ahead of clock - lag")
            if t_ns < first_broadcast + 2 * TICK_NS or (t_ns - START_NS) % TICK_NS:
                continue
            p = state.positions[0]
            worst = max(worst, math.dist((p.x, p.y, p.z), hand(t_ns)))
            for a, b in zip(state.positions, state.positions[1:]):
                worst_link = max(worst_link, abs(math.dist((a.x, a.y, a.z), (b.x, b.y, b.z)) - LINK))
            checked += 1
        self.assertGreater(checked, 50)
        self.assertLess(worst, 1e-6, f"held particle off its frame by up to {worst} m")
        self.assertLess(worst_link, 1e-6, f"links off by up to {worst_link} m")
        # the holder's force sensor reads in its own frame: minus the reaction ~state lists (its
        # last three multipliers, world axes), turned into the hand's (90 degrees about z)
        states = {s.header.stamp: s for s in self.states.since(started)}
        compared = 0
        for wrench in self.wrenches.since(started):
            state = states.get(wrench.header.stamp)
            if state is None:
                continue
            self.assertEqual(wrench.header.frame_id, "hand")
            rx, ry, rz = state.multipliers[-3:]
            f = wrench.wrench.force
            expected = (-ry, rx, -rz)  # R^T (-r) for R = rotation of 90 degrees about z
            scale = math.sqrt(rx * rx + ry * ry + rz * rz)
            self.assertLess(math.dist((f.x, f.y, f.z), expected), 1e-9 * scale,
                            (f, expected))
            compared += 1
        self.assertGreater(compared, 10)


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "frame_anchor", FrameAnchorTest)
