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


THUMB_RADIUS = 0.1  # the sphere ~set_obstacle adds on frame 'thumb' [m]


def eased(moves, ns):
    """Where a holder moving along `moves` is at ROS time ns: each move (start_ns, (x0, z0),
    (x1, z1), seconds) eased (velocity 0 at both ends); before the first, at its start."""
    x, z = moves[0][1]
    for start_ns, (x0, z0), (x1, z1), seconds in moves:
        if ns < start_ns:
            break
        s = min((ns - start_ns) * 1e-9 / seconds, 1.0)
        e = 0.5 * (1.0 - math.cos(math.pi * s))
        x, z = x0 + (x1 - x0) * e, z0 + (z1 - z0) * e
    return x, z


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

    def tick(self, ns, broadcast=True, thumb=None):
        if broadcast:
            frames = [("finger", finger_x(ns), HEIGHT)]
            if thumb is not None:
                frames.append(("thumb",) + eased(thumb, ns))
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

    def run_ticks(self, start_ns, seconds, thumb=None):
        """Ticks /clock (and the frames) from start_ns for `seconds`; the last tick's ns."""
        now, end = start_ns, start_ns + int(seconds * 1e9)
        while now <= end:
            self.tick(now, thumb=thumb)
            now += TICK_NS
            time.sleep(0.01)
        return now - TICK_NS

    def wait_for_stamp(self, last_ns, thumb):
        wanted = stamp_of(last_ns - int(LAG * 1e9))
        self.wait_until(lambda: (self.tick(last_ns, broadcast=False, thumb=thumb),
                                 self.states.latest())[1].header.stamp == wanted,
                        "the state the lag behind the last clock", poll=0.05)

    def deepest(self, states, thumb, finger_radius=None):
        """The deepest any particle went into the thumb (and the finger of `finger_radius`) at
        each state's stamp [m], and the rope's largest x."""
        thumb_depth, finger_depth, pushed = 0.0, 0.0, -math.inf
        for state in states:
            self.assertEqual(state.status, SimState.STATUS_RUNNING, state.status_message)
            t_ns = state.header.stamp.to_nsec()
            x, z = eased(thumb, t_ns)
            for p in state.positions:
                thumb_depth = max(thumb_depth, THUMB_RADIUS + ROPE_RADIUS -
                                  math.dist((p.x, p.y, p.z), (x, 0.0, z)))
                if finger_radius is not None:
                    finger_depth = max(finger_depth, -gap(p, t_ns, finger_radius))
            pushed = max(pushed, max(p.x for p in state.positions))
        return thumb_depth, finger_depth, pushed

    def test_then_set_obstacle_changes_carried_shapes_under_the_rope(self):
        """After the sweep (test_swept_..., run first by name), ~set_obstacle on carried shapes
        (issue 48, item 5): the finger grown on its own frame stays where its frame has it and
        pushes the rope out (the reply says by how much); a sphere added on frame 'thumb' rests
        at its pose as written until the thumb's first pose, then follows it into the rope
        without letting a particle inside, /diagnostics following it and its ~obstacle_wrench
        reading the rope's push; the finger (the first carried shape) removed, the thumb is
        still followed, moving under the pin where the rope falls; a frame of the node's own
        refused naming shape.frame."""
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
        # into the rope's upper run, from clear of it on the pin's other side
        thumb = [(start + TICK_NS, (-0.4, 0.8), (0.1, 0.8), 2.0)]
        last = self.run_ticks(start + TICK_NS, 4.0, thumb=thumb)
        self.wait_for_stamp(last, thumb)
        states = [s for s in self.states.since(since)
                  if s.header.stamp.to_nsec() > start + 3 * TICK_NS]
        self.assertGreater(len(states), 50)
        thumb_depth, finger_depth, pushed = self.deepest(states, thumb, finger_radius=0.1)
        self.assertLess(finger_depth, 1e-6, "a particle inside the grown finger")
        self.assertLess(thumb_depth, 1e-6, "a particle inside the thumb")
        self.assertGreater(pushed, TO_X, "the grown finger no longer holds the rope out")
        # the newest row: the first ones may come before its first pose (on a busy machine)
        rows = [kv.value for a in self.diagnostics.since(since) for s in a.status
                for kv in s.values if kv.key.startswith("obstacle 'thumb' (frame thumb)")]
        self.assertTrue(rows, "no /diagnostics row for the thumb")
        self.assertTrue(rows[-1].startswith("following"), rows[-1])
        wrench = Recorder(f"{NODE}/obstacle_wrench/thumb", WrenchStamped, keep=200)
        self.wait_until(lambda: wrench.subscriber.get_num_connections() > 0,
                        "~obstacle_wrench/thumb advertised")
        listened = time.monotonic()
        last = self.run_ticks(last + TICK_NS, 0.5, thumb=thumb)
        self.wait_for_stamp(last, thumb)
        pushes = [math.hypot(w.wrench.force.x, w.wrench.force.z) for w in wrench.since(listened)]
        self.assertGreater(len(pushes), 3)
        self.assertGreater(min(pushes), 0.05, "the rope does not press on the thumb")
        # the finger, carried shape 0, removed: the thumb (now 0) still followed, moved under
        # the pin where the rope falls back to
        removed = set_obstacle(operation=SetObstacleRequest.REMOVE, name="finger", shape="")
        self.assertTrue(removed.success, removed.message)
        since = time.monotonic()
        thumb.append((last + TICK_NS, (0.1, 0.8), (0.0, 0.75), 1.0))
        moved_from = last + TICK_NS
        last = self.run_ticks(moved_from, 3.0, thumb=thumb)
        self.wait_for_stamp(last, thumb)
        after = [s for s in self.states.since(since) if s.header.stamp.to_nsec() > moved_from]
        self.assertGreater(len(after), 30)
        moved_depth, _, _ = self.deepest(after, thumb)
        self.assertLess(moved_depth, 1e-6, "a particle inside the thumb after the finger went")
        x, z = eased(thumb, after[-1].header.stamp.to_nsec())
        nearest = min(math.dist((p.x, p.y, p.z), (x, 0.0, z)) for p in after[-1].positions)
        self.assertLess(nearest, THUMB_RADIUS + ROPE_RADIUS + 0.02,
                        "the rope does not rest on the thumb under the pin")
        last_rows = [kv.value for a in self.diagnostics.since(since) for s in a.status
                     for kv in s.values if kv.key.startswith("obstacle 'thumb' (frame thumb)")]
        self.assertTrue(last_rows and last_rows[-1].startswith("following"), last_rows[-1:])
        gone = set_obstacle(operation=SetObstacleRequest.REMOVE, name="thumb", shape="")
        self.assertTrue(gone.success, gone.message)
        print(f"set_obstacle: the finger grown to 0.1 m moved the rope out by "
              f"{reply.max_displacement:.4g} m; over {len(states)} states the deepest in the "
              f"finger {finger_depth:.3g} m, in the thumb {thumb_depth:.3g} m; the rope presses "
              f"on the thumb with {min(pushes):.4f}..{max(pushes):.4f} N; the finger removed, "
              f"the thumb moved under the pin: deepest {moved_depth:.3g} m over {len(after)} "
              f"states, the rope {nearest - THUMB_RADIUS - ROPE_RADIUS:.3g} m from it at rest")


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "carried_obstacle", CarriedObstacleTest)
