#!/usr/bin/python3
"""What a user sees and touches (views.test): the particle cloud, tf's frame cap, the latched
surface and view, grab-and-drag through interactive marker feedback, and ~apply_force. Every
wait is polled under a wall-clock deadline."""
import math
import os
import sys
import time
import unittest

import rospy
import rostest
from constrained_particles.msg import SceneView, SimState
from constrained_particles.srv import (ApplyForce, ClearForces, Reset, SetChain, SetSurface, Step)
from dynamic_reconfigure.client import Client
from geometry_msgs.msg import Vector3
from rosgraph_msgs.msg import Log
from sensor_msgs import point_cloud2
from sensor_msgs.msg import PointCloud2
from std_srvs.srv import Empty
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import (InteractiveMarkerFeedback, InteractiveMarkerUpdate, Marker,
                                    MarkerArray)
from topic_recorder import Recorder
from wall_clock import WallClockWaits

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
import drag  # noqa: E402 (scripts/drag.py: the feedback rviz sends)

NODE = "/simulator"
NAN, INF = float("nan"), float("inf")


def distance(a, b):
    return math.sqrt((a.x - b[0]) ** 2 + (a.y - b[1]) ** 2 + (a.z - b[2]) ** 2)


class ViewsTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("views_test")
        names = ("reset", "set_chain", "set_surface", "pause", "unpause", "step", "apply_force",
                 "clear_forces")
        for name in names:
            rospy.wait_for_service(f"{NODE}/{name}", timeout=60.0)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        cls.set_chain = rospy.ServiceProxy(f"{NODE}/set_chain", SetChain)
        cls.set_surface = rospy.ServiceProxy(f"{NODE}/set_surface", SetSurface)
        cls.pause = rospy.ServiceProxy(f"{NODE}/pause", Empty)
        cls.unpause = rospy.ServiceProxy(f"{NODE}/unpause", Empty)
        cls.step = rospy.ServiceProxy(f"{NODE}/step", Step)
        cls.apply_force = rospy.ServiceProxy(f"{NODE}/apply_force", ApplyForce)
        cls.clear_forces = rospy.ServiceProxy(f"{NODE}/clear_forces", ClearForces)
        cls.reconfigure = Client(NODE, timeout=60.0)
        cls.states = Recorder(f"{NODE}/state", SimState)
        cls.logs = Recorder("/rosout", Log, keep=2000)
        cls.feedback = rospy.Publisher(f"{NODE}/grab/feedback", InteractiveMarkerFeedback,
                                       queue_size=10)

    def setUp(self):
        self.pause()
        self.reconfigure.update_configuration({"tf_frames": -1, "interactive": False,
                                               "gravity_z": -9.81})
        self.assertTrue(self.reset("chain").success)

    def fresh_state(self, after=None, predicate=lambda s: True):
        """A ~state published after wall time `after` (default: now) that satisfies predicate."""
        start = time.monotonic() if after is None else after
        return self.wait_until(
            lambda: next((s for s in reversed(self.states.since(start)) if predicate(s)), None),
            "a fresh ~state")

    # --- ~particles ---

    def test_particles_cloud_matches_state(self):
        cloud = Recorder(f"{NODE}/particles", PointCloud2, keep=20)
        try:
            self.assertTrue(self.set_chain(num_particles=40, link_length=0.2,
                                           particle_mass=0.5).success)
            self.step(300)
            state = self.fresh_state(predicate=lambda s: s.steps == 300)
            message = self.wait_until(
                lambda: next((c for c in reversed(cloud.since(0))
                              if c.header.stamp >= state.header.stamp), None), "~particles")
            self.assertEqual(message.header.frame_id, "world")
            self.assertEqual([f.name for f in message.fields], ["x", "y", "z", "force"])
            self.assertEqual(message.width * message.height, 40)
            points = list(point_cloud2.read_points(message, field_names=("x", "y", "z", "force")))
            self.assertEqual(len(points), 40)
            for point, p, f in zip(points, state.positions, state.constraint_forces):
                # float32: 7 significant digits
                for got, want in zip(point[:3], (p.x, p.y, p.z)):
                    self.assertAlmostEqual(got, want, delta=1e-6 * (1 + abs(want)))
                magnitude = math.sqrt(f.x ** 2 + f.y ** 2 + f.z ** 2)
                self.assertAlmostEqual(point[3], magnitude, delta=1e-6 * (1 + magnitude))
        finally:
            cloud.subscriber.unregister()

    # --- ~tf_frames ---

    def test_tf_frames_caps_and_warns(self):
        tf = Recorder("/tf", TFMessage, keep=50)
        try:
            start = time.monotonic()
            self.assertTrue(self.set_chain(num_particles=1500, link_length=0.01,
                                           particle_mass=0.01).success)
            self.unpause()
            capped = self.wait_until(
                lambda: next((m for m in tf.since(start) if len(m.transforms) == 1000), None),
                "/tf with 1000 frames")
            self.assertEqual(capped.transforms[-1].child_frame_id, "particle_999")
            warning = self.wait_until(
                lambda: next((m for m in self.logs.since(start)
                              if m.name == NODE and m.level == Log.WARN and
                              "1500 particles" in m.msg and "first 1000" in m.msg), None),
                "the one-line warning on /rosout")
            self.assertIn("~tf_frames", warning.msg)
            # once per scene: no second warning while it runs
            time.sleep(1.0)
            self.assertEqual(len([m for m in self.logs.since(start)
                                  if m.name == NODE and "first 1000" in m.msg]), 1)
            # the first N, then none
            self.reconfigure.update_configuration({"tf_frames": 7})
            asked = time.monotonic()
            self.wait_until(lambda: any(len(m.transforms) == 7 for m in tf.since(asked)),
                            "/tf with 7 frames")
            self.reconfigure.update_configuration({"tf_frames": 0})
            asked = time.monotonic()
            # what was in flight arrives within a publish period or two; then nothing
            self.wait_until(lambda: self.fresh_state(after=asked), "~state after tf_frames 0")
            quiet = time.monotonic() + 0.3
            self.wait_until(lambda: time.monotonic() > quiet, "a moment")
            settled = time.monotonic()
            self.wait_until(lambda: len(self.states.since(settled)) >= 20,
                            "20 more ~state messages")
            self.assertEqual(tf.since(settled), [])
        finally:
            tf.subscriber.unregister()
            self.pause()

    # --- ~surface and ~view, latched ---

    def test_late_subscribers_get_the_current_scene(self):
        # changed while nobody listens to ~surface or ~view
        self.assertTrue(self.reset("bead").success)
        self.assertTrue(self.set_surface(type="plane", coefficients=[0.1, -0.2, 0.3], expression="").success)
        surface = Recorder(f"{NODE}/surface", MarkerArray, keep=5)
        view = Recorder(f"{NODE}/view", SceneView, keep=5)
        try:
            mesh = self.wait_until(surface.latest, "the latched ~surface").markers[0]
            self.assertEqual((mesh.ns, mesh.type, mesh.action),
                             ("surface", Marker.TRIANGLE_LIST, Marker.ADD))
            self.assertGreater(len(mesh.points), 0)
            for p in mesh.points:  # the plane z = 0.1 x - 0.2 y + 0.3, not the bowl
                self.assertAlmostEqual(p.z, 0.1 * p.x - 0.2 * p.y + 0.3, places=9)
            current = self.wait_until(view.latest, "the latched ~view")
            self.assertEqual(current.scenario, "bead")
            # the bead's region (its file's), and the bead inside it
            state = self.fresh_state()
            p = state.positions[0]
            for axis in ("x", "y", "z"):
                self.assertLess(getattr(current.low, axis), getattr(p, axis))
                self.assertGreater(getattr(current.high, axis), getattr(p, axis))
            xs = [q.x for q in mesh.points]
            self.assertAlmostEqual(min(xs), current.low.x, places=9)
            self.assertAlmostEqual(max(xs), current.high.x, places=9)
        finally:
            surface.subscriber.unregister()
            view.subscriber.unregister()
        # a scene without a surface: a late subscriber is told to delete the mesh
        self.assertTrue(self.reset("chain").success)
        self.fresh_state(predicate=lambda s: s.scenario == "chain")
        surface = Recorder(f"{NODE}/surface", MarkerArray, keep=5)
        try:
            mesh = self.wait_until(surface.latest, "the latched ~surface").markers[0]
            self.assertEqual((mesh.ns, mesh.action), ("surface", Marker.DELETE))
        finally:
            surface.subscriber.unregister()

    # --- grab and drag ---

    def send(self, particle, event, position):
        # the message scripts/drag.py sends, as rviz sends it
        self.feedback.publish(drag.feedback("world", particle, event, position))

    def test_drag_pulls_towards_the_marker_and_release_ends_it(self):
        # the markers are made on the next publish: an update (not a keep-alive) that holds them
        update = Recorder(f"{NODE}/grab/update", InteractiveMarkerUpdate, keep=20)
        try:
            self.wait_until(lambda: update.subscriber.get_num_connections() > 0, "~grab/update")
            self.wait_until(lambda: self.feedback.get_num_connections() > 0, "~grab/feedback")
            # no gravity: only the drag moves the pinned chain (links 0.5 m, the tip 2 m out)
            self.reconfigure.update_configuration({"gravity_z": 0.0, "interactive": True})
            self.assertTrue(self.reset("").success)
            self.wait_until(lambda: any(u.type == InteractiveMarkerUpdate.UPDATE and
                                        any(m.name == "4" for m in u.markers)
                                        for u in update.since(0)), "~grab's markers")
        finally:
            update.subscriber.unregister()
        tip = self.fresh_state().positions[4]
        target = (1.0, 0.0, 1.0)  # within the chain's reach
        start_distance = distance(tip, target)
        self.send(4, InteractiveMarkerFeedback.MOUSE_DOWN, (tip.x, tip.y, tip.z))
        self.send(4, InteractiveMarkerFeedback.POSE_UPDATE, target)
        started = time.monotonic()
        self.unpause()
        # held, and pulled: the spring is evaluated in the steps since
        self.fresh_state(predicate=lambda s: s.dragged_particles == 1 and
                         "target_spring" in s.effect_names)

        def keep_holding():
            # rviz repeats the pose while the mouse is held
            self.send(4, InteractiveMarkerFeedback.POSE_UPDATE, target)
            state = self.states.latest()
            return state if distance(state.positions[4], target) < 0.2 * start_distance else None
        near = self.wait_until(keep_holding, "the tip pulled near the marker", timeout=60.0,
                               poll=0.05)
        self.assertGreater(near.sim_time, 0.1)
        # the links held throughout (projection_tolerance 1e-10 m)
        during = [s for s in self.states.since(started) if s.scenario == "chain"]
        self.assertGreater(len(during), 5)
        self.assertLessEqual(max(s.max_position_error for s in during), 1e-10 * (1 + 1e-6))
        # released: the spring goes, and stays gone
        self.send(4, InteractiveMarkerFeedback.MOUSE_UP, target)
        released = time.monotonic()
        self.fresh_state(after=released, predicate=lambda s: s.dragged_particles == 0)
        later = time.monotonic()
        self.wait_until(lambda: len(self.states.since(later)) >= 10, "10 more ~state messages")
        for state in self.states.since(later):
            self.assertEqual(state.dragged_particles, 0)
            self.assertNotIn("target_spring", state.effect_names)
        self.pause()

    # --- ~apply_force ---

    def test_apply_force_on_a_bead_on_a_plane_matches_the_closed_form(self):
        self.assertTrue(self.reset("bead").success)
        self.assertTrue(self.set_surface(type="plane", coefficients=[0.0, 0.0, 0.0], expression="").success)
        start = self.fresh_state(predicate=lambda s: s.scenario == "bead" and s.steps == 0)
        p0, v0 = start.positions[0], start.velocities[0]
        self.assertAlmostEqual(p0.z, 0.0, places=12)
        # F = 2 N along x on the 1 kg bead for 0.5 s: x = x0 + a t^2 / 2, then a t1 (t - t1)
        reply = self.apply_force(0, Vector3(2.0, 0.0, 0.0), 0.5)
        self.assertTrue(reply.success, reply.message)
        self.assertEqual(self.fresh_state().applied_forces, 1)
        stepped = self.step(1000)  # dt 1 ms: 1 s
        self.assertTrue(stepped.success, stepped.message)
        end = self.fresh_state(predicate=lambda s: s.steps == 1000)
        a, t1, t = 2.0, 0.5, 1.0
        self.assertAlmostEqual(end.positions[0].x, p0.x + 0.5 * a * t1 ** 2 + a * t1 * (t - t1),
                               places=9)
        self.assertAlmostEqual(end.positions[0].y, p0.y + v0.y * t, places=9)
        self.assertAlmostEqual(end.positions[0].z, 0.0, places=9)
        self.assertAlmostEqual(end.velocities[0].x, a * t1, places=9)
        self.assertEqual(end.applied_forces, 0)  # its time is up
        # until cleared: acts on every step, counted as an external force, until ~clear_forces
        self.assertTrue(self.apply_force(0, Vector3(0.0, 1.0, 0.0), 0.0).success)
        self.step(10)
        held = self.fresh_state(predicate=lambda s: s.steps == 1010)
        self.assertEqual(held.applied_forces, 1)
        self.assertIn("external", held.effect_names)
        cleared = self.clear_forces()
        self.assertTrue(cleared.success)
        self.assertIn("cleared 1", cleared.message)
        self.assertEqual(self.fresh_state().applied_forces, 0)

    def test_bad_force_requests_are_refused_naming_the_field(self):
        self.assertTrue(self.reset("bead").success)
        before = self.fresh_state(predicate=lambda s: s.scenario == "bead")
        cases = [
            ((1, Vector3(1.0, 0.0, 0.0), 1.0), "particle"),
            ((7, Vector3(1.0, 0.0, 0.0), 1.0), "particle"),
            ((0, Vector3(NAN, 0.0, 0.0), 1.0), "force.x"),
            ((0, Vector3(0.0, INF, 0.0), 1.0), "force.y"),
            ((0, Vector3(0.0, 0.0, -1e10), 1.0), "force.z"),
            ((0, Vector3(1.0, 0.0, 0.0), -1.0), "duration"),
            ((0, Vector3(1.0, 0.0, 0.0), NAN), "duration"),
            ((0, Vector3(1.0, 0.0, 0.0), INF), "duration"),
        ]
        for request, field in cases:
            reply = self.apply_force(*request)
            self.assertFalse(reply.success, request)
            self.assertTrue(reply.message.startswith(field), (field, reply.message))
            self.assertIn("must", reply.message)
        after = self.fresh_state()
        self.assertEqual(after.applied_forces, 0)
        self.assertEqual(after.steps, before.steps)
        self.assertEqual([(p.x, p.y, p.z) for p in after.positions],
                         [(p.x, p.y, p.z) for p in before.positions])


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "views", ViewsTest)
