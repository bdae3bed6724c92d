#!/usr/bin/python3
"""A capsule on tf frame 'finger' sweeps through a hanging rope (issue 48, item 1): every ~state
stamped T has no particle inside the capsule at the finger's pose at T, the rope is pushed along,
/diagnostics follows the finger, and at rest the finger's ~obstacle_wrench and the pin's
~anchor_wrench together carry the rope's weight (statics). Then ~set_obstacle changes carried
shapes under the rope: the finger grown on its frame, a sphere added on frame 'thumb' swept into
the rope, a frame of the node's own refused."""
import math
import time
import unittest

import rospy
import rostest
import tf2_ros
from constrained_particles.msg import SimState
from constrained_particles.srv import SetObstacle, SetObstacleRequest
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


def gap(p, ns, radius=RADIUS):
    """The particle's ball's distance out of the capsule (axis along y) at time ns [m]."""
    x = finger_x(ns)
    y = min(max(p.y, -HALF), HALF)
    return math.dist((p.x, p.y, p.z), (x, y, HEIGHT)) - radius - ROPE_RADIUS


THUMB_RADIUS, THUMB_Z = 0.1, 0.8  # the sphere ~set_obstacle adds on frame 'thumb' [m]
THUMB_FROM_X, THUMB_TO_X, THUMB_SWEEP = -0.4, 0.1, 2.0  # its path after the sweep [m], [s]


def thumb_x(ns, since_ns):
    """The thumb's x at ROS time ns, its sweep starting at since_ns (velocity 0 at both ends)."""
    s = min(max((ns - since_ns) * 1e-9 / THUMB_SWEEP, 0.0), 1.0)
    return THUMB_FROM_X + (THUMB_TO_X - THUMB_FROM_X) * 0.5 * (1.0 - math.cos(math.pi * s))


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

    def tick(self, ns, broadcast=True, thumb_since=None):
        if broadcast:
            frames = [("finger", finger_x(ns), HEIGHT)]
            if thumb_since is not None:
                frames.append(("thumb", thumb_x(ns, thumb_since), THUMB_Z))
            transforms = []
            for name, x, z in frames:
                t = TransformStamped()
                t.header.stamp = stamp_of(ns)
                t.header.frame_id = "world"
                t.child_frame_id = name
                t.transform.translation.x = x
                t.transform.translation.z = z
                t.transform.rotation.w = 1.0
                transforms.append(t)
            self.tf.sendTransform(transforms)
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
        CarriedObstacleTest.last_ns = last

    def run_ticks(self, start_ns, seconds, thumb_since=None):
        """Ticks /clock (and the frames) from start_ns for `seconds`; the last tick's ns."""
        now, end = start_ns, start_ns + int(seconds * 1e9)
        while now <= end:
            self.tick(now, thumb_since=thumb_since)
            now += TICK_NS
            time.sleep(0.01)
        return now - TICK_NS

    def wait_for_stamp(self, last_ns):
        wanted = stamp_of(last_ns - int(LAG * 1e9))
        self.wait_until(lambda: (self.tick(last_ns, broadcast=False), self.states.latest())[1]
                        .header.stamp == wanted, "the state the lag behind the last clock",
                        poll=0.05)

    def test_then_set_obstacle_changes_carried_shapes_under_the_rope(self):
        """After the sweep (test_swept_..., run first by name), ~set_obstacle on carried shapes
        (issue 48, item 5): the finger grown on its own frame stays where its frame has it and
        pushes the rope out (the reply says by how much); a sphere added on frame 'thumb' rests
        at its pose as written until the thumb's first pose, then follows it, sweeping into the
        rope without letting a particle inside, /diagnostics following it and its
        ~obstacle_wrench reading the rope's push; a frame of the node's own refused naming
        shape.frame; the thumb removed."""
        start = getattr(CarriedObstacleTest, "last_ns", None)
        self.assertIsNotNone(start, "the sweep's test did not run first")
        set_obstacle = rospy.ServiceProxy(f"{NODE}/set_obstacle", SetObstacle)
        set_obstacle.wait_for_service(timeout=30.0)
        grown = ("{type: capsule, frame: finger, rpy: [1.5707963267948966, 0.0, 0.0], "
                 "radius: 0.1, length: 0.3}")
        reply = set_obstacle(operation=SetObstacleRequest.REPLACE, name="finger", shape=grown)
        self.assertTrue(reply.success, reply.message)
        self.assertGreater(reply.max_displacement, 0.005, reply.message)
        refused = set_obstacle(operation=SetObstacleRequest.ADD, name="nail",
                               shape="{type: sphere, frame: particle_3}")
        self.assertFalse(refused.success)
        self.assertIn("shape.frame", refused.message)
        self.assertIn("~frame_prefix", refused.message)
        added = set_obstacle(operation=SetObstacleRequest.ADD, name="thumb",
                             shape=f"{{type: sphere, frame: thumb, radius: {THUMB_RADIUS}}}")
        self.assertTrue(added.success, added.message)
        self.assertEqual(added.max_displacement, 0.0, added.message)  # as written: at the origin
        since = time.monotonic()
        thumb_since = start + TICK_NS
        last = self.run_ticks(thumb_since, THUMB_SWEEP + 2.0, thumb_since=thumb_since)
        self.wait_for_stamp(last)
        states = [s for s in self.states.since(since)
                  if s.header.stamp.to_nsec() > thumb_since + 2 * TICK_NS]
        self.assertGreater(len(states), 50)
        deepest_finger, deepest_thumb, pushed = 0.0, 0.0, 0.0
        for state in states:
            self.assertEqual(state.status, SimState.STATUS_RUNNING, state.status_message)
            t_ns = state.header.stamp.to_nsec()
            centre = (thumb_x(t_ns, thumb_since), 0.0, THUMB_Z)
            for p in state.positions:
                deepest_finger = max(deepest_finger, -gap(p, t_ns, 0.1))
                deepest_thumb = max(deepest_thumb, THUMB_RADIUS + ROPE_RADIUS -
                                    math.dist((p.x, p.y, p.z), centre))
            pushed = max(pushed, max(p.x for p in state.positions))
        self.assertLess(deepest_finger, 1e-6, "a particle inside the grown finger")
        self.assertLess(deepest_thumb, 1e-6, "a particle inside the thumb")
        self.assertGreater(pushed, TO_X, "the grown finger no longer holds the rope out")
        row = next((kv.value for a in self.diagnostics.since(since) for s in a.status
                    for kv in s.values if kv.key.startswith("obstacle 'thumb' (frame thumb)")),
                   None)
        self.assertIsNotNone(row, "no /diagnostics row for the thumb")
        self.assertTrue(row.startswith("following"), row)
        thumb = Recorder(f"{NODE}/obstacle_wrench/thumb", WrenchStamped, keep=200)
        self.wait_until(lambda: thumb.subscriber.get_num_connections() > 0,
                        "~obstacle_wrench/thumb advertised")
        listened = time.monotonic()
        last = self.run_ticks(last + TICK_NS, 0.5, thumb_since=thumb_since)
        self.wait_for_stamp(last)
        pushes = [math.hypot(w.wrench.force.x, w.wrench.force.z) for w in thumb.since(listened)]
        self.assertGreater(len(pushes), 3)
        self.assertGreater(min(pushes), 0.05, "the rope does not press on the thumb")
        removed = set_obstacle(operation=SetObstacleRequest.REMOVE, name="thumb", shape="")
        self.assertTrue(removed.success, removed.message)
        print(f"set_obstacle: the finger grown to 0.1 m moved the rope out by "
              f"{reply.max_displacement:.4g} m; over {len(states)} states the deepest in the "
              f"finger {deepest_finger:.3g} m, in the thumb {deepest_thumb:.3g} m; the rope "
              f"presses on the thumb with {min(pushes):.4f}..{max(pushes):.4f} N")


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "carried_obstacle", CarriedObstacleTest)
