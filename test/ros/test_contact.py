#!/usr/bin/python3
"""Contact through the node (issues 35, 48): surface_chain_contact for 10 s keeps every particle
on or above the bowl and its links exact, with no fault, ~state naming the touching particles; a
rope slides off its table without going into it; a rope dropped over a post stays out of it and
its floor and loads both; obstacles change under it (~set_obstacle). Waits are wall-clock deadlines with polling."""
import math
import unittest

import rospy
import rostest
from topic_recorder import Recorder
from wall_clock import WallClockWaits
from constrained_particles.msg import SimState
from constrained_particles.srv import Reset, SetObstacle, SetObstacleRequest, SetSurface, Step
from std_srvs.srv import Empty
from geometry_msgs.msg import WrenchStamped
from visualization_msgs.msg import Marker, MarkerArray
import time

NODE = "/simulator"
TOLERANCE = 1e-9  # [m]


def bowl(x, y):
    return (x * x + y * y) / 2.0


def table(x, y):
    return -0.5 * (1.0 + math.tanh(20.0 * (x - 0.5)))


class ContactTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("contact_test")
        for name in ("pause", "step", "reset"):
            rospy.wait_for_service(f"{NODE}/{name}", timeout=60.0)
        cls.pause = rospy.ServiceProxy(f"{NODE}/pause", Empty)
        cls.step = rospy.ServiceProxy(f"{NODE}/step", Step)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        cls.states = Recorder(f"{NODE}/state", SimState)

    def run_scene(self, scenario, surface, seconds, link=None, outside=None):
        """Steps `scenario` `seconds` in chunks of 0.1 s, checking the state after each: no
        particle below `surface` by more than TOLERANCE (nor, given `outside`, a gap function of
        a position, inside by more), links of `link` [m] exact to it, no fault. Returns the last
        state."""
        self.pause()
        reply = self.reset(scenario)
        self.assertTrue(reply.success, reply.message)
        state = None
        for chunk in range(int(round(seconds / 0.1))):
            reply = self.step(100)
            self.assertTrue(reply.success, reply.message)
            since = time.monotonic()
            t = reply.sim_time
            state = self.wait_until(
                lambda: next((s for s in self.states.since(since - 1.0)
                              if s.scenario == scenario and abs(s.sim_time - t) < 1e-9), None),
                f"~state of {scenario} at t = {t}")
            self.assertNotEqual(state.status, SimState.STATUS_FAULT, state.status_message)
            for i, p in enumerate(state.positions):
                self.assertGreaterEqual(p.z - surface(p.x, p.y), -TOLERANCE,
                                        f"{scenario}: particle {i} below at t = {t}")
                if outside is not None:
                    self.assertGreaterEqual(outside(p), -TOLERANCE,
                                            f"{scenario}: particle {i} inside at t = {t}")
            if link is not None:
                for a, b in zip(state.positions, state.positions[1:]):
                    length = math.dist((a.x, a.y, a.z), (b.x, b.y, b.z))
                    self.assertLessEqual(abs(length - link), TOLERANCE, f"t = {t}")
            self.assertLessEqual(state.max_position_error, TOLERANCE, f"t = {t}")
        return state

    def step_on(self, chunks, start, gap):
        """Steps `chunks` chunks of 0.1 s from sim time `start` [s] (the time goes on: no reset),
        checking the state after each: no fault, gap(p) >= -TOLERANCE for every particle (p's
        distance outside what its contacts keep it out of). Returns the last state."""
        state = None
        for chunk in range(chunks):
            step = self.step(100)
            self.assertTrue(step.success, step.message)
            self.assertAlmostEqual(step.sim_time, start + 0.1 * (chunk + 1), delta=1e-9)
            since = time.monotonic()
            state = self.wait_until(
                lambda: next((s for s in self.states.since(since - 1.0)
                              if abs(s.sim_time - step.sim_time) < 1e-9), None),
                f"~state at t = {step.sim_time}")
            self.assertNotEqual(state.status, SimState.STATUS_FAULT, state.status_message)
            for i, p in enumerate(state.positions):
                self.assertGreaterEqual(gap(p), -TOLERANCE,
                                        f"particle {i} inside at t = {state.sim_time}")
        return state

    def test_chain_rests_in_the_bowl(self):
        last = self.run_scene("surface_chain_contact", bowl, 10.0, link=0.5)
        # every particle but the first (a surface row holds it) touches, pushed by the bowl
        self.assertEqual(sorted(last.contact_particles), [1, 2, 3, 4])
        self.assertEqual(len(last.contact_normal_forces), 4)
        self.assertEqual(len(last.contact_friction_forces), 4)
        for force in last.contact_normal_forces:
            self.assertGreater(force, 0.0)
        for mode in last.contact_modes:
            self.assertIn(mode, (SimState.CONTACT_SLIDING, SimState.CONTACT_STICKING))

    def test_rope_slides_off_the_table(self):
        last = self.run_scene("rope_on_table", table, 3.0, link=0.1)
        # the rope's end that lay on the table went over its edge at x = 0.5 to the floor
        self.assertGreater(last.positions[0].x, 0.6)
        self.assertLess(last.positions[0].z, -0.9)

    def test_rope_lies_over_the_post(self):
        """rope_over_post (issue 48): a rope of radius 1 cm dropped over a post (a cylinder of
        radius 5 cm on the y axis at z = 0.5) onto a floor: never inside either over 4 s, its
        middle over the post and its ends on the floor, both obstacles loaded
        (~obstacle_wrench/<shape>, stamped as ~state), ~obstacles drawing both. The loads' sum
        against the weight at rest is test_obstacle_wrenches' (core, closed form)."""
        markers = Recorder(f"{NODE}/obstacles", MarkerArray)
        post = Recorder(f"{NODE}/obstacle_wrench/post", WrenchStamped)
        floor = Recorder(f"{NODE}/obstacle_wrench/floor", WrenchStamped)

        def post_gap(p):  # the post's axis is y: distance from it in x-z, less both radii
            return math.hypot(p.x, p.z - 0.5) - 0.05 - 0.01

        last = self.run_scene("rope_over_post", lambda x, y: 0.01, 4.0, link=0.05,
                              outside=post_gap)
        # it hangs over the post: its middle on it, its ends on the floor
        middle = last.positions[len(last.positions) // 2]
        self.assertGreater(middle.z, 0.5)
        self.assertLess(last.positions[0].z, 0.02)
        self.assertLess(last.positions[-1].z, 0.02)
        # the loads published with the last state (one stamp for a state's outputs)
        def with_last_stamp(recorder):
            return next((m for m in reversed(recorder.since(0.0))
                         if m.header.stamp == last.header.stamp), None)
        loads = self.wait_until(
            lambda: (with_last_stamp(post), with_last_stamp(floor))
            if with_last_stamp(post) and with_last_stamp(floor) else None,
            "~obstacle_wrench/post and /floor stamped as the last ~state")
        weight = 30 * 0.02 * 9.81
        carried = -(loads[0].wrench.force.z + loads[1].wrench.force.z)
        rospy.loginfo("rope_over_post: post carries %.4f N, floor %.4f N, of the rope's %.4f N; "
                      "fastest particle %.3g m/s; touching %s",
                      -loads[0].wrench.force.z, -loads[1].wrench.force.z, weight,
                      max(math.sqrt(v.x ** 2 + v.y ** 2 + v.z ** 2) for v in last.velocities),
                      list(last.contact_particles))
        # still swinging at 4 s (friction 0.5 damps it slowly): each carries a part of it, down,
        # and together not more than the rope and its motion can put on them
        self.assertLess(carried, 2.0 * weight)
        self.assertGreater(-loads[0].wrench.force.z, 0.1 * weight)
        self.assertGreater(-loads[1].wrench.force.z, 0.1 * weight)
        drawn = self.wait_until(
            lambda: next((m for m in reversed(markers.since(0.0))
                          if len(m.markers) == 3), None), "~obstacles with both shapes")
        types = sorted(m.type for m in drawn.markers[1:])
        self.assertEqual(types, sorted([Marker.CYLINDER, Marker.CUBE]))

    def test_surface_changed_under_the_resting_chain_keeps_the_state(self):
        """~set_surface keep_state (issue 48, item 5): the bowl under surface_chain_contact made
        steeper after 3 s: no reset (the time goes on), the reply says how far the particles
        were lifted, every particle on or above the new bowl then and over 2 s more."""
        set_surface = rospy.ServiceProxy(f"{NODE}/set_surface", SetSurface)
        before = self.run_scene("surface_chain_contact", bowl, 3.0, link=0.5)
        steeper = lambda x, y: 0.75 * (x * x + y * y)
        self.assertGreater(max(steeper(p.x, p.y) - p.z for p in before.positions), 1e-3)
        since = time.monotonic()
        reply = set_surface(type="bowl", coefficients=[1.5, 1.5], expression="", keep_state=True)
        self.assertTrue(reply.success, reply.message)
        # the state at the same time on the new bowl (paused, the state before the change may
        # still be published, and arrive, after the reply: it lies below the new bowl), moved by
        # what the reply says
        def on_new_bowl(s):
            return abs(s.sim_time - before.sim_time) < 1e-9 and all(
                p.z - steeper(p.x, p.y) >= -TOLERANCE for p in s.positions)
        after = self.wait_until(
            lambda: next((s for s in self.states.since(since) if on_new_bowl(s)), None),
            "~state at the change's time on the new bowl")
        moved = max(math.dist((a.x, a.y, a.z), (b.x, b.y, b.z))
                    for a, b in zip(before.positions, after.positions))
        self.assertGreater(moved, 1e-3)
        self.assertAlmostEqual(reply.max_displacement, moved, delta=1e-9)
        # the time goes on from 3 s: kept, not reset
        self.step_on(20, 3.0, lambda p: p.z - steeper(p.x, p.y))
        bad = set_surface(type="bowl", coefficients=[-1.0], expression="", keep_state=True)
        self.assertFalse(bad.success)
        self.assertIn("coefficients", bad.message)

    def test_obstacles_change_under_the_draped_rope_and_keep_the_state(self):
        """~set_obstacle (issue 48, item 5) on rope_over_post after 2 s: the post grown from 5 cm
        to 8 cm pushes the rope out (the reply says how far, the time goes on, nothing inside the
        new post over 1 s more); a shape added far away moves nothing and is drawn; bad requests
        are refused naming their field with the time unchanged; the post removed, the rope falls
        to the floor."""
        set_obstacle = rospy.ServiceProxy(f"{NODE}/set_obstacle", SetObstacle)
        markers = Recorder(f"{NODE}/obstacles", MarkerArray)

        def gap(radius):
            return lambda p: math.hypot(p.x, p.z - 0.5) - radius - 0.01

        before = self.run_scene("rope_over_post", lambda x, y: 0.01, 2.0, link=0.05,
                                outside=gap(0.05))
        self.assertLess(min(gap(0.08)(p) for p in before.positions), -0.02)
        since = time.monotonic()
        grown = ("{type: cylinder, position: [0, 0, 0.5], rpy: [1.5707963267948966, 0, 0], "
                 "radius: 0.08, length: 0.8}")
        reply = set_obstacle(operation=SetObstacleRequest.REPLACE, name="post",
                             shape=grown)
        self.assertTrue(reply.success, reply.message)
        after = self.wait_until(
            lambda: next((s for s in self.states.since(since)
                          if abs(s.sim_time - before.sim_time) < 1e-9 and
                          all(gap(0.08)(p) >= -TOLERANCE for p in s.positions)), None),
            "~state at the change's time outside the grown post")
        moved = max(math.dist((a.x, a.y, a.z), (b.x, b.y, b.z))
                    for a, b in zip(before.positions, after.positions))
        self.assertGreater(moved, 0.02)
        self.assertAlmostEqual(reply.max_displacement, moved, delta=1e-9)
        print(f"set_obstacle: the post grown to 8 cm moved the rope out by up to {moved:.4g} m "
              f"at t = {before.sim_time:.3f} s ({reply.message})")

        self.step_on(10, 2.0, lambda p: min(p.z - 0.01, gap(0.08)(p)))
        # bad requests: refused, naming the field, nothing changed
        for request, field in (
                (dict(operation=7, name="post", shape=""), "operation"),
                (dict(operation=SetObstacleRequest.REPLACE, name="post",
                      shape="{type: cylinder, radius: -1}"), "radius"),
                (dict(operation=SetObstacleRequest.REMOVE, name="pole", shape=""),
                 "name"),
                (dict(operation=SetObstacleRequest.ADD, name="post",
                      shape="{type: sphere}"), "name")):
            bad = set_obstacle(**request)
            self.assertFalse(bad.success, request)
            self.assertIn(field, bad.message)
        # added far away: nothing moves, three shapes drawn
        since = time.monotonic()
        added = set_obstacle(operation=SetObstacleRequest.ADD, name="ball",
                             shape="{type: sphere, position: [0, 0, 3], radius: 0.1}")
        self.assertTrue(added.success, added.message)
        self.assertEqual(added.max_displacement, 0.0)
        self.wait_until(lambda: next((m for m in markers.since(since)
                                      if len(m.markers) == 4), None),
                        "~obstacles with the post, the floor and the ball")
        # the post removed: the rope falls to the floor (z = 0.01 its radius)
        removed = set_obstacle(operation=SetObstacleRequest.REMOVE, name="post",
                               shape="")
        self.assertTrue(removed.success, removed.message)
        state = self.step_on(10, 3.0, lambda p: p.z - 0.01)
        self.assertLess(max(p.z for p in state.positions), 0.1)


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "contact", ContactTest)
