#!/usr/bin/python3
"""frame_anchor on a PoseStamped topic: followed in any tf frame; bad poses dropped and counted."""
import math
import time
import unittest

import rospy
import rostest
import tf2_ros
from constrained_particles.msg import SimState
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TransformStamped
from topic_recorder import Recorder, diagnostic_value, publish_for
from wall_clock import WallClockWaits

NODE = "/simulator"
OFFSET_Z = -0.05  # pose_rope.yaml's offset, in the pose's frame [m]


def pose(frame, x, y, z, qw=1.0, qz=0.0):
    msg = PoseStamped()
    msg.header.stamp = rospy.Time.now()
    msg.header.frame_id = frame
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = x, y, z
    msg.pose.orientation.w, msg.pose.orientation.z = qw, qz
    return msg


class FrameAnchorPoseTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("frame_anchor_pose_test")
        cls.states = Recorder(f"{NODE}/state", SimState, keep=2000)
        cls.diagnostics = Recorder("/diagnostics", DiagnosticArray, keep=20)
        cls.poses = rospy.Publisher("/gripper_pose", PoseStamped, queue_size=100)
        rospy.wait_for_service(f"{NODE}/reset", timeout=60.0)
        # 'table' is world moved 1 m along x: a pose in it is resolved through tf (/tf_static)
        cls.static = tf2_ros.StaticTransformBroadcaster()
        table = TransformStamped()
        table.header.stamp = rospy.Time.now()
        table.header.frame_id = "world"
        table.child_frame_id = "table"
        table.transform.translation.x = 1.0
        table.transform.rotation.w = 1.0
        cls.static.sendTransform(table)

    def holder_status(self, since):
        return diagnostic_value(self.diagnostics, since, "frame_anchor 0")

    def hold(self, frame, x, y, z, seconds, bad=()):
        """Publishes the pose at 30 Hz for `seconds` (and the `bad` messages once, halfway)."""
        publish_for(self.poses, lambda: pose(frame, x, y, z), seconds, bad=bad)

    def at_rest_at(self, point, since):
        states = self.states.since(since)
        if not states:
            return False
        p = states[-1].positions[0]
        return math.dist((p.x, p.y, p.z), point) < 1e-9

    def test_poses_followed_bad_ones_counted(self):
        self.wait_until(lambda: self.poses.get_num_connections() > 0, "the node subscribing")
        # in world: the held point is the pose plus its offset
        started = time.monotonic()
        self.hold("world", 0.1, 0.0, 1.0, 2.0)
        self.wait_until(lambda: (self.poses.publish(pose("world", 0.1, 0.0, 1.0)),
                                 self.at_rest_at((0.1, 0.0, 1.0 + OFFSET_Z), started))[1],
                        "the held particle at the pose in world", poll=0.05)
        # in 'table' (world + 1 m in x), turned 90 degrees about z: the offset is along z, so
        # the held point is (1.1, 0.2, 0.95); with a NaN pose and an unnormalised one between
        bad_nan = pose("table", float("nan"), 0.0, 1.0)
        bad_quaternion = pose("table", 0.1, 0.2, 1.0, qw=2.0)
        started = time.monotonic()
        self.hold("table", 0.1, 0.2, 1.0, 3.0, bad=(bad_nan, bad_quaternion))
        self.wait_until(
            lambda: (self.poses.publish(pose("table", 0.1, 0.2, 1.0, qw=math.sqrt(0.5),
                                             qz=math.sqrt(0.5))),
                     self.at_rest_at((1.1, 0.2, 1.0 + OFFSET_Z), started))[1],
            "the held particle at the pose in 'table'", poll=0.05)
        status = self.wait_until(
            lambda: (lambda v: v if v and "non-finite 2" in v else None)(
                self.holder_status(started)), "the two bad poses counted", poll=0.1)
        self.assertIn("teleports 1", status)  # 1 m from world's pose to the table's
        state = self.states.latest()
        self.assertEqual(state.status, SimState.STATUS_RUNNING)
        self.assertTrue(all(math.isfinite(c) for p in state.positions for c in (p.x, p.y, p.z)))
        self.assertEqual(list(state.holders), ["/gripper_pose"])


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "frame_anchor_pose", FrameAnchorPoseTest)
