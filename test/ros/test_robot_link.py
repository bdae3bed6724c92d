#!/usr/bin/python3
"""A rope dropped onto a URDF link (issue 48, item 1): the test robot's forearm box, from
robot_description, on its tf frame (/tf_static); the rope never inside it, at rest on its top,
the link's ~obstacle_wrench carrying the rope's weight, ~obstacles drawing it on its frame. With
~mesh true (robot_mesh_link.test) the box is the link's <mesh>: drawn as its 12 triangles."""
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
from visualization_msgs.msg import Marker, MarkerArray
from topic_recorder import Recorder
from wall_clock import WallClockWaits

NODE = "/simulator"
START_NS = 1_733_000_000_000_000_000
TICK_NS = 10_000_000
LINK, TURN = (0.0, 0.0, 0.5), 0.6  # the forearm frame: 0.5 m up, turned 0.6 rad about z
# test_robot.urdf's forearm collision: a box of 0.6 x 0.3 x 0.1 at (0.1, 0, -0.05), yaw 0.2
ORIGIN, YAW, HALF = (0.1, 0.0, -0.05), 0.2, (0.3, 0.15, 0.05)
RADIUS, MASS, PARTICLES, G = 0.01, 0.05, 5, 9.81


def turned(angle, v):
    """v turned by angle about z."""
    c, s = math.cos(angle), math.sin(angle)
    return (c * v[0] - s * v[1], s * v[0] + c * v[1], v[2])


CENTRE = tuple(a + b for a, b in zip(LINK, turned(TURN, ORIGIN)))


def box_gap(p):
    """The particle's ball's signed distance out of the box [m] (negative: inside)."""
    q = turned(-(TURN + YAW), (p.x - CENTRE[0], p.y - CENTRE[1], p.z - CENTRE[2]))
    d = [abs(c) - h for c, h in zip(q, HALF)]
    outside = math.sqrt(sum(max(c, 0.0) ** 2 for c in d))
    return (outside if outside > 0.0 else max(d)) - RADIUS


class RobotLinkTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("robot_link_test")
        cls.states = Recorder(f"{NODE}/state", SimState, keep=5000)
        cls.diagnostics = Recorder("/diagnostics", DiagnosticArray, keep=50)
        cls.wrenches = Recorder(f"{NODE}/obstacle_wrench/forearm", WrenchStamped, keep=2000)
        cls.obstacles = Recorder(f"{NODE}/obstacles", MarkerArray, keep=10)
        cls.clock = rospy.Publisher("/clock", Clock, queue_size=100)
        cls.tf = tf2_ros.StaticTransformBroadcaster()

    def tick(self, ns):
        msg = Clock()
        msg.clock = rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000)
        self.clock.publish(msg)

    def test_rope_rests_on_the_link(self):
        t = TransformStamped()
        t.header.frame_id = "world"
        t.child_frame_id = "forearm"
        t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = LINK
        t.transform.rotation.z = math.sin(TURN / 2)
        t.transform.rotation.w = math.cos(TURN / 2)
        self.tf.sendTransform(t)
        self.wait_until(lambda: self.clock.get_num_connections() > 0, "the node subscribing")
        self.wait_until(lambda: self.wrenches.subscriber.get_num_connections() > 0,
                        "~obstacle_wrench/forearm advertised")
        # the node follows the link's static frame before the clock starts
        started = time.monotonic()
        now = START_NS
        self.tick(now)

        def following():
            self.tick(now)
            return next((kv.value for a in self.diagnostics.since(started) for s in a.status
                         for kv in s.values if kv.key.startswith("obstacle 'forearm'")
                         and kv.value.startswith("following")), None)
        self.wait_until(following, "/diagnostics following the forearm", poll=0.2)
        ticking = time.monotonic()
        for _ in range(200):  # 2 s of clock
            now += TICK_NS
            self.tick(now)
            time.sleep(0.01)

        def settled():
            self.tick(now)
            s = self.states.latest()
            return s if s is not None and s.sim_time > 1.9 else None
        last_state = self.wait_until(settled, "the state near 2 s", poll=0.05)
        states = self.states.since(ticking)
        self.assertGreater(len(states), 20)
        deepest = max(-box_gap(p) for s in states for p in s.positions)
        self.assertLess(deepest, 1e-9, f"a particle {deepest} m inside the forearm")
        for p in last_state.positions:
            self.assertAlmostEqual(p.z, 0.5 + RADIUS, delta=1e-9)
        for v in last_state.velocities:
            self.assertLess(math.sqrt(v.x * v.x + v.y * v.y + v.z * v.z), 1e-9)
        weight = PARTICLES * MASS * G
        wrench = next(w for w in reversed(self.wrenches.since(ticking))
                      if w.header.stamp == last_state.header.stamp)
        f = wrench.wrench.force
        self.assertLess(math.dist((f.x, f.y, f.z), (0.0, 0.0, -weight)), 1e-9 * weight, f)
        # ~obstacles draws the link on its frame: a CUBE of its size, or its mesh's triangles
        drawn = self.wait_until(
            lambda: next((m for a in reversed(self.obstacles.since(0.0)) for m in a.markers
                          if m.ns == "obstacles" and m.action == Marker.ADD), None),
            "the forearm in ~obstacles")
        self.assertEqual(drawn.header.frame_id, "forearm")
        if rospy.get_param("~mesh", False):
            self.assertEqual(drawn.type, Marker.TRIANGLE_LIST)
            self.assertEqual(len(drawn.points), 36)
            for q in drawn.points:  # a corner of the box, in its own frame
                for c, h in zip((q.x, q.y, q.z), HALF):
                    self.assertAlmostEqual(abs(c), h, delta=1e-12)
        else:
            self.assertEqual(drawn.type, Marker.CUBE)
            for size, h in zip((drawn.scale.x, drawn.scale.y, drawn.scale.z), HALF):
                self.assertAlmostEqual(size, 2 * h, delta=1e-12)
        print(f"deepest {deepest:.3g} m over {len(states)} states; at rest on the forearm, "
              f"its wrench ({f.x:.3g}, {f.y:.3g}, {f.z:.12f}) N against weight {weight} N")


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "robot_link", RobotLinkTest)
