#!/usr/bin/python3
"""A capsule on tf frame 'finger' sweeps through a hanging rope (issue 48, item 1): every ~state
stamped T has no particle inside the capsule at the finger's pose at T, the rope is pushed along,
/diagnostics follows the finger, and at rest the finger's ~obstacle_wrench and the pin's
~anchor_wrench together carry the rope's weight (statics)."""
import math
import time
import unittest

import rospy
import rostest
import tf2_ros
from constrained_particles.msg import SimState
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TransformStamped, WrenchStamped
from rosgraph_msgs.msg import Clock
from topic_recorder import Recorder
from wall_clock import WallClockWaits

NODE = "/simulator"
START_NS = 1_733_000_000_000_000_000  # the first clock, a multiple of the tick (ns)
TICK_NS = 10_000_000  # /clock and the finger advance in 10 ms ticks
LAG = 0.3  # ~anchor_lag [s]
STILL, SWEEP, REST = 1.0, 4.0, 3.0  # the finger waits, sweeps, then rests [s]
FROM_X, TO_X, HEIGHT = -0.4, 0.3, 0.55  # its path [m]
RADIUS, HALF, ROPE_RADIUS = 0.08, 0.15, 0.01  # the capsule's radius and half-length, the rope's
MASS, PARTICLES, G = 0.1, 8, 9.81


def finger_x(ns):
    """The finger's x at ROS time ns: still, then a smooth sweep (velocity 0 at both ends)."""
    s = min(max(((ns - START_NS) * 1e-9 - STILL) / SWEEP, 0.0), 1.0)
    return FROM_X + (TO_X - FROM_X) * 0.5 * (1.0 - math.cos(math.pi * s))


def stamp_of(ns):
    return rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000)


def gap(p, ns):
    """The particle's ball's distance out of the capsule (axis along y) at time ns [m]."""
    x = finger_x(ns)
    y = min(max(p.y, -HALF), HALF)
    return math.dist((p.x, p.y, p.z), (x, y, HEIGHT)) - RADIUS - ROPE_RADIUS


class CarriedObstacleTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("carried_obstacle_test")
        cls.states = Recorder(f"{NODE}/state", SimState, keep=5000)
        cls.diagnostics = Recorder("/diagnostics", DiagnosticArray, keep=20)
        cls.finger = Recorder(f"{NODE}/obstacle_wrench/finger", WrenchStamped, keep=2000)
        cls.pin = Recorder(f"{NODE}/anchor_wrench/particle_0", WrenchStamped, keep=2000)
        cls.clock = rospy.Publisher("/clock", Clock, queue_size=100)
        cls.tf = tf2_ros.TransformBroadcaster()

    def tick(self, ns, broadcast=True):
        if broadcast:
            t = TransformStamped()
            t.header.stamp = stamp_of(ns)
            t.header.frame_id = "world"
            t.child_frame_id = "finger"
            t.transform.translation.x = finger_x(ns)
            t.transform.translation.z = HEIGHT
            t.transform.rotation.w = 1.0
            self.tf.sendTransform(t)
        msg = Clock()
        msg.clock = stamp_of(ns)
        self.clock.publish(msg)

    def test_swept_capsule_pushes_the_rope_and_reads_its_load(self):
        self.wait_until(lambda: self.clock.get_num_connections() > 0, "the node subscribing")
        self.wait_until(lambda: self.finger.subscriber.get_num_connections() > 0,
                        "~obstacle_wrench/finger advertised")
        started = time.monotonic()
        now = START_NS
        end = START_NS + int((STILL + SWEEP + REST) * 1e9)
        while now <= end:
            self.tick(now)
            now += TICK_NS
            time.sleep(0.01)
        last = now - TICK_NS
        wanted = stamp_of(last - int(LAG * 1e9))
        self.wait_until(lambda: (self.tick(last, broadcast=False), self.states.latest())[1]
                        .header.stamp == wanted, "the state the lag behind the last clock",
                        poll=0.05)
        states = [s for s in self.states.since(started)
                  if s.header.stamp.to_nsec() >= START_NS + 2 * TICK_NS]
        self.assertGreater(len(states), 100)
        deepest, pushed = 0.0, 0.0
        for state in states:
            self.assertEqual(state.status, SimState.STATUS_RUNNING, state.status_message)
            t_ns = state.header.stamp.to_nsec()
            for p in state.positions:
                self.assertTrue(all(math.isfinite(c) for c in (p.x, p.y, p.z)))
                deepest = max(deepest, -gap(p, t_ns))
            pushed = max(pushed, max(p.x for p in state.positions))
        self.assertLess(deepest, 1e-6, f"a particle {deepest} m inside the finger")
        self.assertGreater(pushed, TO_X, "the rope was not pushed along by the finger")
        bottom = states[-1].positions[-1]
        self.assertGreater(bottom.x, TO_X, "the rope's end does not hang past the finger")
        # the finger is followed, by name, in /diagnostics
        row = next((kv.value for a in self.diagnostics.since(started) for s in a.status
                    for kv in s.values if kv.key.startswith("obstacle 'finger' (frame finger)")),
                   None)
        self.assertIsNotNone(row, "no /diagnostics row for the finger")
        self.assertTrue(row.startswith("following"), row)
        # before the sweep the finger carries nothing; at rest, with the pin, the rope's weight
        before = [w for w in self.finger.since(started)
                  if w.header.stamp.to_nsec() < START_NS + int(STILL * 1e9)]
        self.assertGreater(len(before), 5)
        for w in before:
            f = w.wrench.force
            self.assertEqual((f.x, f.y, f.z), (0.0, 0.0, 0.0))
        pins = {w.header.stamp: w for w in self.pin.since(started)}
        settled = START_NS + int((STILL + SWEEP + REST - 0.5) * 1e9)
        compared = 0
        weight = PARTICLES * MASS * G
        for w in self.finger.since(started):
            if w.header.stamp.to_nsec() < settled or w.header.stamp not in pins:
                continue
            f, q = w.wrench.force, pins[w.header.stamp].wrench.force
            self.assertLess(f.x, -0.1, "the finger does not feel the rope pulling back")
            total = (f.x + q.x, f.y + q.y, f.z + q.z)
            self.assertLess(math.dist(total, (0.0, 0.0, -weight)), 1e-3 * weight, (f, q))
            compared += 1
        self.assertGreater(compared, 3)
        print(f"deepest {deepest:.3g} m inside over {len(states)} states; rope pushed to x = "
              f"{pushed:.4f} m; at rest finger ({f.x:.4f}, {f.y:.4f}, {f.z:.4f}) N + pin "
              f"({q.x:.4f}, {q.y:.4f}, {q.z:.4f}) N against weight {weight:.4f} N, off by "
              f"{math.dist(total, (0.0, 0.0, -weight)):.3g} N ({compared} pairs)")


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "carried_obstacle", CarriedObstacleTest)
