#!/usr/bin/python3
"""An obstacle on a PoseStamped topic: bad poses dropped and counted, a flood taken, the state
finite and the obstacle's wrench its load throughout."""
import math
import time
import unittest

import rospy
import rostest
from constrained_particles.msg import SimState
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, WrenchStamped
from visualization_msgs.msg import Marker, MarkerArray
from topic_recorder import Recorder, diagnostic_value, publish_for
from wall_clock import WallClockWaits

NODE = "/simulator"
WEIGHT = 2 * 0.1 * 9.81  # pose_paddle.yaml: two particles of 0.1 kg [N]
ON_TOP = 0.05 + 0.01  # the paddle's top face plus the particles' radius [m]
ROW = "obstacle 'paddle' (topic /paddle_pose)"


def pose(x=0.0, y=0.0, z=0.0, qw=1.0):
    msg = PoseStamped()
    msg.header.stamp = rospy.Time.now()
    msg.header.frame_id = "world"
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = x, y, z
    msg.pose.orientation.w = qw
    return msg


def finite_state(state):
    return all(math.isfinite(c) for p in list(state.positions) + list(state.velocities)
               for c in (p.x, p.y, p.z))


class ObstaclePoseTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("obstacle_pose_test")
        cls.states = Recorder(f"{NODE}/state", SimState, keep=2000)
        cls.diagnostics = Recorder("/diagnostics", DiagnosticArray, keep=20)
        cls.wrenches = Recorder(f"{NODE}/obstacle_wrench/paddle", WrenchStamped, keep=2000)
        cls.poses = rospy.Publisher("/paddle_pose", PoseStamped, queue_size=100)
        cls.obstacles = Recorder(f"{NODE}/obstacles", MarkerArray, keep=200)
        rospy.wait_for_service(f"{NODE}/reset", timeout=60.0)

    def publish_for(self, seconds, bad=(), z=0.0):
        """The paddle's pose (at height z, level) at 30 Hz for `seconds`, and each of `bad`
        once, halfway."""
        publish_for(self.poses, lambda: pose(z=z), seconds, bad=bad)

    def paddle_marker(self, since):
        """The newest ~obstacles CUBE since `since` (the paddle), or None."""
        for array in reversed(self.obstacles.since(since)):
            for marker in array.markers:
                if marker.ns == "obstacles" and marker.type == Marker.CUBE:
                    return marker
        return None

    def check_resting(self, since, what):
        """Every state since `since` finite and running, the particles on the paddle's top, and
        the newest wrench the particles' weight."""
        states = self.states.since(since)
        self.assertTrue(states, what)
        for state in states:
            self.assertEqual(state.status, SimState.STATUS_RUNNING, what)
            self.assertTrue(finite_state(state), what)
            for p in state.positions:
                self.assertAlmostEqual(p.z, ON_TOP, delta=1e-6, msg=what)
        wrench = self.wrenches.latest()
        self.assertIsNotNone(wrench, what)
        force = wrench.wrench.force
        self.assertTrue(all(math.isfinite(c) for c in (force.x, force.y, force.z)), what)
        self.assertAlmostEqual(force.z, -WEIGHT, delta=1e-6 * WEIGHT, msg=what)

    def test_bad_poses_dropped_and_a_flood_taken(self):
        self.wait_until(lambda: self.poses.get_num_connections() > 0, "the node subscribing")
        started = time.monotonic()
        self.publish_for(2.0)
        self.wait_until(lambda: (lambda v: v if v and v.startswith("following") else None)(
            diagnostic_value(self.diagnostics, started, ROW)), "the paddle followed", poll=0.1)
        self.check_resting(started + 1.0, "following the paddle")
        # a NaN position and a quaternion of length 2: dropped, counted, nothing else changed
        started = time.monotonic()
        self.publish_for(2.0, bad=(pose(x=float("nan")), pose(qw=2.0)))
        status = self.wait_until(
            lambda: (lambda v: v if v and "non-finite 2" in v else None)(
                diagnostic_value(self.diagnostics, started, ROW)),
            "the two bad poses counted", poll=0.1)
        self.assertIn("teleports 0", status)
        self.check_resting(started, "after the bad poses")
        state = self.states.latest()
        self.assertEqual(list(state.carried_obstacles), ["paddle"])
        self.assertEqual(list(state.obstacle_holders), ["/paddle_pose"])
        self.assertEqual(list(state.obstacle_teleports), [0])
        self.assertEqual(list(state.holders), [])  # no particle is held
        # a flood: 5,000 poses as fast as they go, then the 30 Hz stream again
        started = time.monotonic()
        for _ in range(5000):
            self.poses.publish(pose())
        self.publish_for(2.0)
        self.check_resting(started, "after the flood")
        # the stream goes on while waiting: a pause over ~1 s would read as its publisher stopped
        self.assertIsNotNone(self.wait_until(
            lambda: (self.poses.publish(pose()),
                     (lambda v: v if v and v.startswith("following") else None)(
                         diagnostic_value(self.diagnostics, time.monotonic() - 1.0, ROW)))[1],
            "the paddle still followed", poll=0.05))
        # drawn in rviz where its topic puts it: raised 5 cm, the marker goes with it, in the
        # fixed frame (its pose as written is the origin: only a moved marker shows the track)
        started = time.monotonic()
        self.publish_for(2.0, z=0.05)
        marker = self.wait_until(
            lambda: (lambda m: m if m and abs(m.pose.position.z - 0.05) < 1e-9 else None)(
                self.paddle_marker(started)), "the paddle's marker raised with it", poll=0.1)
        self.assertEqual(marker.header.frame_id, "world")
        self.assertEqual(self.states.latest().status, SimState.STATUS_RUNNING)


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "obstacle_pose", ObstaclePoseTest)
