#!/usr/bin/python3
"""frame_anchor on wall time: a broadcaster that stops holds up nothing, the particle coasts on
and comes to rest, said; a teleport carries the rope."""
import math
import statistics
import threading
import time
import unittest

import rospy
import rostest
import tf2_ros
from dynamic_reconfigure.client import Client
from constrained_particles.msg import SimState
from constrained_particles.srv import ApplyForce, Attach, Detach, Reset
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TransformStamped, Vector3
from tf2_msgs.msg import TFMessage
from topic_recorder import Recorder, diagnostic_value
from wall_clock import WallClockWaits

NODE = "/simulator"
LINK = 0.12  # hold_the_rope's links [m]


class Broadcaster:
    """Sends frame 'hand' at 30 Hz, stamped now, at where(t) until stopped."""

    def __init__(self, where):
        self.where = where
        self.last = None  # the last position sent
        self.running = True
        self.tf = tf2_ros.TransformBroadcaster()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        start = time.monotonic()
        while self.running and not rospy.is_shutdown():
            t = TransformStamped()
            t.header.stamp = rospy.Time.now()
            t.header.frame_id = "world"
            t.child_frame_id = "hand"
            (t.transform.translation.x, t.transform.translation.y,
             t.transform.translation.z) = self.last = self.where(time.monotonic() - start)
            t.transform.rotation.w = 1.0
            self.tf.sendTransform(t)
            time.sleep(1.0 / 30.0)

    def stop(self):
        self.running = False
        self.thread.join()


def rate(items, start, end):
    return len([1 for t in items if start <= t <= end]) / (end - start)


class FrameAnchorWallTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("frame_anchor_wall_test")
        cls.states = Recorder(f"{NODE}/state", SimState, keep=5000)
        cls.diagnostics = Recorder("/diagnostics", DiagnosticArray, keep=20)
        cls.tf_times = []
        cls.tf_sub = rospy.Subscriber("/tf", TFMessage, cls.on_tf, queue_size=100)
        rospy.wait_for_service(f"{NODE}/reset", timeout=60.0)

    @classmethod
    def on_tf(cls, msg):
        if any(t.child_frame_id == "particle_0" for t in msg.transforms):
            cls.tf_times.append(time.monotonic())

    def holder_status(self, since):
        return diagnostic_value(self.diagnostics, since, "frame_anchor 0")

    def test_holders_said_truly_when_static_and_when_faulted(self):
        # a frame on /tf_static holds the tip: following, still, never "stopped"
        static = tf2_ros.StaticTransformBroadcaster()
        shelf = TransformStamped()
        shelf.header.stamp = rospy.Time.now()
        shelf.header.frame_id = "world"
        shelf.child_frame_id = "shelf"
        shelf.transform.translation.x, shelf.transform.translation.z = 0.3, 0.6
        shelf.transform.rotation.w = 1.0
        static.sendTransform(shelf)
        attach = rospy.ServiceProxy(f"{NODE}/attach", Attach)
        detach = rospy.ServiceProxy(f"{NODE}/detach", Detach)
        reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        reply = self.wait_until(lambda: (lambda r: r if r.success else None)(
            attach(7, "shelf", Vector3(), True)), "the tip attached to the static frame", poll=0.5)
        self.assertEqual(reply.moved, 0.0)
        start = time.monotonic()
        time.sleep(2.5)  # longer than the 1 s a moving holder may stay silent
        value = self.wait_until(lambda: diagnostic_value(self.diagnostics, start + 1.5,
                                                         "frame_anchor 7"), "the shelf's status")
        self.assertTrue(value.startswith("following (a static frame"), value)
        self.assertNotIn("arrived", value)
        self.assertTrue(detach(7).success)
        # while the scene is faulted a broadcasting holder is still said to broadcast
        reconfigure = Client(NODE, timeout=60.0)
        settings = reconfigure.get_configuration(timeout=60.0)
        broadcaster = Broadcaster(lambda t: (0.0, 0.0, 1.5))
        try:
            self.wait_until(lambda: (self.holder_status(time.monotonic() - 1.5) or "").startswith(
                "following"), "the node following frame 'hand'", poll=0.1)
            # explicit Euler without stabilisation or sub-steps at dt = 0.05 s: the push drives
            # the constraint error past ~max_constraint_error, a fault (as in blow_up.test)
            reconfigure.update_configuration({"integrator": "explicit_euler",
                                              "stabilization": "none", "max_substeps": 1,
                                              "energy_budget": 0.0, "dt": 0.05})
            push = rospy.ServiceProxy(f"{NODE}/apply_force", ApplyForce)
            self.assertTrue(push(3, Vector3(10.0, 0.0, 0.0), 0.0).success)
            self.wait_until(lambda: self.states.latest().status == SimState.STATUS_FAULT,
                            "the fault the push makes")
            faulted = time.monotonic()
            time.sleep(2.5)  # longer than the 1 s after which a silent holder is "stopped?"
            value = self.wait_until(lambda: self.holder_status(faulted + 1.5),
                                    "the hand's status while faulted")
            self.assertIn("stepping is stopped", value)
            self.assertNotIn("arrived", value)  # its broadcasts still arrive
        finally:
            broadcaster.stop()
            reconfigure.update_configuration({key: settings[key] for key in (
                "integrator", "stabilization", "max_substeps", "energy_budget", "dt")})
            self.assertTrue(reset("").success)

    def test_attach_refusals(self):
        attach = rospy.ServiceProxy(f"{NODE}/attach", Attach)
        # particle 1's only link goes to particle 0, which the scene's frame_anchor holds
        reply = attach(1, "hand", Vector3(), False)
        self.assertFalse(reply.success)
        self.assertTrue(reply.message.startswith("particle = 1: its link joins it to held"),
                        reply.message)
        # a particle frame of the node itself
        reply = attach(5, "particle_3", Vector3(), False)
        self.assertFalse(reply.success)
        self.assertTrue(reply.message.startswith("frame = 'particle_3' is one of this node's"),
                        reply.message)
        self.assertEqual(list(self.states.latest().held_particles), [0])

    def test_a_stopped_broadcaster_holds_up_nothing(self):
        # a circle of 0.2 m at 0.5 Hz about the start (0, 0, 1.5)
        broadcaster = Broadcaster(lambda t: (0.2 * math.sin(math.pi * t),
                                             0.2 * (1.0 - math.cos(math.pi * t)), 1.5))
        self.wait_until(lambda: (self.holder_status(time.monotonic() - 1.5) or "").startswith(
            "following"), "the node following frame 'hand'", poll=0.1)
        time.sleep(1.0)
        before_start = time.monotonic()
        time.sleep(3.0)
        before_end = time.monotonic()
        # it followed the circle (0.4 m across) while it moved
        xs = [s.positions[0].x for s in self.states.since(before_start, before_end)]
        self.assertGreater(max(xs) - min(xs), 0.35)
        self.assertLess(max(abs(x) for x in xs), 0.2 + 1e-9)
        broadcaster.stop()
        last = broadcaster.last  # the frame rests at its last pose
        after_start = time.monotonic()
        time.sleep(3.0)
        after_end = time.monotonic()
        tf_times = list(self.tf_times)
        state_times = [t for t, _ in self.states.items]
        for name, times in (("tf", tf_times), ("~state", state_times)):
            before = rate(times, before_start, before_end)
            after = rate(times, after_start, after_end)
            self.assertGreater(before, 10.0, f"{name} at {before} Hz while the frame moved")
            self.assertGreater(after, 0.7 * before,
                               f"{name} fell from {before} to {after} Hz when the frame stopped")
        # past the frame's last pose the held particle coasted on, slowing to rest within 0.25 s
        # (AnchorTrack's horizon): it rests at most its speed (0.63 m/s on the circle) times
        # 0.125 s beyond the last pose, and the node said the steps ran past it
        rest = [s.positions[0] for s in self.states.since(after_end - 1.0)]
        self.assertTrue(rest)
        spread = max(math.dist((a.x, a.y, a.z), (rest[-1].x, rest[-1].y, rest[-1].z))
                     for a in rest)
        self.assertLess(spread, 1e-12, "the held particle still moves after its frame stopped")
        drift = math.dist((rest[-1].x, rest[-1].y, rest[-1].z), last)
        self.assertLess(drift, 0.2 * math.pi * 0.125 + 1e-3,
                        "the held particle coasted farther than it could")
        self.assertGreaterEqual(self.states.latest().holder_overruns[0], 1)
        status = self.holder_status(after_start)
        self.assertIn("its newest pose arrived", status)
        # a teleport: the frame jumps 2 m (more than ~anchor_max_jump) and the rope is carried
        teleport_start = time.monotonic()
        jumped = Broadcaster(lambda t: (2.0, 0.0, 1.5))
        try:
            status = self.wait_until(
                lambda: (lambda v: v if v and "teleports 1" in v else None)(
                    self.holder_status(teleport_start)), "a teleport counted", poll=0.1)
            self.assertIn("teleports 1 (last", status)
            state = self.wait_until(
                lambda: (lambda s: s if s and abs(s.positions[0].x - 2.0) < 1e-9 else None)(
                    self.states.latest()), "the held particle at the frame's new pose", poll=0.05)
            for a, b in zip(state.positions, state.positions[1:]):
                self.assertLess(abs(math.dist((a.x, a.y, a.z), (b.x, b.y, b.z)) - LINK), 1e-6)
            self.assertEqual(state.status, SimState.STATUS_RUNNING)
        finally:
            jumped.stop()


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "frame_anchor_wall", FrameAnchorWallTest)
