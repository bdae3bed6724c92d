#!/usr/bin/python3
"""Drives a running simulator_node through tf, ~state, markers, services and reconfigure."""
import math
import os
import tempfile
import time
import unittest

import dynamic_reconfigure.client
import rospy
import rostest
from wall_clock import WallClockWaits
import tf2_ros
from constrained_particles.msg import SceneView, SimState
from constrained_particles.srv import ListScenes, Reset, SetChain, SetState, SetSurface, Step
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import Point, Vector3
from std_srvs.srv import Empty
from visualization_msgs.msg import Marker, MarkerArray

NODE = "/simulator"
# wall-clock bound on a wait for something that must happen (generous: a loaded machine)
WAIT = 30.0
NAN = float("nan")
INF = float("inf")


def positions_of(state):
    return [(p.x, p.y, p.z) for p in state.positions]


def distance(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


class SimulatorInterfaceTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("simulator_interface_test")
        for name in ("reset", "list_scenes", "set_surface", "set_chain", "set_state", "pause",
                     "unpause", "step"):
            rospy.wait_for_service(f"{NODE}/{name}", timeout=60.0)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        cls.list_scenes = rospy.ServiceProxy(f"{NODE}/list_scenes", ListScenes)
        cls.set_surface = rospy.ServiceProxy(f"{NODE}/set_surface", SetSurface)
        cls.set_chain = rospy.ServiceProxy(f"{NODE}/set_chain", SetChain)
        cls.set_state = rospy.ServiceProxy(f"{NODE}/set_state", SetState)
        cls.pause = rospy.ServiceProxy(f"{NODE}/pause", Empty)
        cls.unpause = rospy.ServiceProxy(f"{NODE}/unpause", Empty)
        cls.step = rospy.ServiceProxy(f"{NODE}/step", Step)
        cls.latest_state = None
        cls.states_received = 0
        cls.latest_forces = None
        cls.deleted_arrows = set()
        cls.latest_scene = None
        rospy.Subscriber(f"{NODE}/state", SimState, cls._on_state, queue_size=1)
        # every marker array counts (the one deleting stale arrows is sent once): no dropping
        rospy.Subscriber(f"{NODE}/constraint_forces", MarkerArray, cls._on_forces, queue_size=100)
        rospy.Subscriber(f"{NODE}/scene", MarkerArray, cls._on_scene, queue_size=1)
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)

    @classmethod
    def _on_state(cls, msg):
        cls.latest_state = msg
        cls.states_received += 1

    @classmethod
    def _on_forces(cls, msg):
        cls.latest_forces = msg
        cls.deleted_arrows |= {m.id for m in msg.markers if m.action == Marker.DELETE}

    @classmethod
    def _on_scene(cls, msg):
        cls.latest_scene = msg

    def setUp(self):
        # every test starts paused at a known scene: surface_chain as its file says
        self.pause()
        self.assertTrue(self.reset("surface_chain").success)

    def tearDown(self):
        self.pause()


    def fresh_state(self, timeout=WAIT):
        """A state published after this call (not one already in flight)."""
        start = rospy.Time.now()
        self.wait_until(lambda: self.latest_state is not None and
                        self.latest_state.header.stamp > start, "a new ~state", timeout)
        return self.latest_state

    def state_after(self, earlier):
        """The first state seen whose sim time moved on from `earlier`'s."""
        return self.wait_until(
            lambda: self.latest_state if self.latest_state.sim_time > earlier.sim_time else None,
            f"a ~state past sim time {earlier.sim_time} s")

    def assert_refused(self, response, field):
        self.assertFalse(response.success, f"accepted, expected refusal naming {field}")
        self.assertIn(field, response.message)

    def assert_unchanged(self, before):
        after = self.fresh_state()
        self.assertEqual(after.scenario, before.scenario)
        self.assertEqual(after.sim_time, before.sim_time)
        self.assertEqual(after.steps, before.steps)
        self.assertEqual(positions_of(after), positions_of(before))

    def assert_finite(self, state):
        for value in [c for p in positions_of(state) for c in p] + list(state.multipliers):
            self.assertTrue(math.isfinite(value))

    # --- ~state and tf ---

    def test_state_is_published_and_advances(self):
        self.unpause()
        first = self.state_after(self.fresh_state())
        second = self.state_after(first)
        self.assertEqual(second.scenario, "surface_chain")
        self.assertEqual(len(second.positions), 5)
        self.assertEqual(len(second.velocities), 5)
        self.assertEqual(len(second.constraint_forces), 5)
        self.assertEqual(len(second.multipliers), 5)  # surface + 4 links
        self.assertGreater(second.sim_time, first.sim_time)
        self.assertGreater(second.steps, first.steps)
        self.assertGreater(second.step_time, 0.0)
        self.assertLess(second.max_position_error, 1e-8)
        self.assertEqual(second.header.frame_id, "world")
        self.assert_finite(second)

    def test_a_hanging_ropes_tensions_are_the_weight_below_each_link(self):
        """~state reads what the rope carries: a rope of the user's own scene file hanging at rest
        from a pin, each link's tension the weight below it (1e-9 of it), each bend straight."""
        n, mass = 6, 0.3
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "hanging_rope.yaml")
            with open(path, "w") as f:
                f.write(f"chains:\n  - {{particles: {n}, link_length: 0.2, particle_mass: {mass}, "
                        "start: [0, 0, 1], direction: [0, 0, -1], pin_first: true, "
                        "bend_stiffness: 0.1}\nforces:\n  - {type: gravity}\n")
            response = self.reset(path)
            self.assertTrue(response.success, response.message)
        self.unpause()
        state = self.wait_until(
            lambda: self.latest_state if self.latest_state is not None and
            self.latest_state.scenario == "hanging_rope" and self.latest_state.steps > 0 else None,
            "a ~state of the hanging rope, stepped")
        self.assertEqual(list(state.link_first), list(range(n - 1)))
        self.assertEqual(list(state.link_second), list(range(1, n)))
        for k, tension in enumerate(state.link_tensions):
            below = (n - 1 - k) * mass * 9.81
            self.assertAlmostEqual(tension / below, 1.0, delta=1e-9, msg=f"link {k}")
        self.assertEqual(len(state.link_tensions), n - 1)
        self.assertEqual(list(state.bend_particles), list(range(1, n - 1)))
        self.assertLess(max(state.bending_moments), 1e-9)

    def test_tf_frames_match_state(self):
        state = self.fresh_state()
        for i, position in enumerate(positions_of(state)):
            frame = f"particle_{i}"
            # polled in wall time (can_transform's own timeout runs in rospy time)
            deadline = time.monotonic() + WAIT
            while not self.tf_buffer.can_transform("world", frame, state.header.stamp) and \
                    time.monotonic() < deadline:
                time.sleep(0.01)
            self.assertTrue(self.tf_buffer.can_transform("world", frame, state.header.stamp),
                            f"{frame} does not resolve from world")
            transform = self.tf_buffer.lookup_transform("world", frame, state.header.stamp)
            t = transform.transform.translation
            # tf2's Python buffer keeps stamps as doubles: equal to well under a microsecond
            self.assertLess(abs((transform.header.stamp - state.header.stamp).to_sec()), 1e-6)
            self.assertAlmostEqual(t.x, position[0], places=12)
            self.assertAlmostEqual(t.y, position[1], places=12)
            self.assertAlmostEqual(t.z, position[2], places=12)

    # --- ~reset ---

    def test_reset(self):
        self.unpause()
        self.state_after(self.fresh_state())
        self.pause()
        self.assertGreater(self.fresh_state().sim_time, 0.0)
        response = self.reset("chain")
        self.assertTrue(response.success, response.message)
        state = self.fresh_state()
        self.assertEqual(state.scenario, "chain")
        self.assertEqual(state.sim_time, 0.0)
        self.assertEqual(state.steps, 0)
        self.assertEqual(positions_of(state)[0], (0.0, 0.0, 0.0))
        # empty = current scenario
        self.assertTrue(self.reset("").success)
        self.assertEqual(self.fresh_state().scenario, "chain")
        before = self.fresh_state()
        for bad in ("pendulum", "CHAIN", "x" * 10000):
            self.assert_refused(self.reset(bad), "scenario")
            self.assert_unchanged(before)

    def assert_on_constraints(self, state, tolerance=1e-8):
        self.assert_finite(state)
        self.assertLess(state.max_position_error, tolerance)

    # --- scenes: ~list_scenes, ~reset by name or path, changes to the current scene ---

    def test_list_and_load_every_scene(self):
        listed = self.list_scenes()
        for required in ("bead", "chain", "surface_chain", "pinned_pendulum",
                         "chain_pinned_both_ends", "two_chains_on_surface", "bead_with_drag",
                         "zigzag_chain", "bead_on_wire", "sled_on_ramp", "shaken_chain",
                         "stiff_rod"):
            self.assertIn(required, listed.names)
        self.assertEqual(listed.names, sorted(listed.names))
        for name in listed.names:
            response = self.reset(name)
            self.assertTrue(response.success, response.message)
            self.step(50)
            state = self.fresh_state()
            self.assertEqual(state.scenario, name)
            self.assertEqual(state.steps, 50)
            self.assert_on_constraints(state)
        # by path, as a user's own scene would be given
        response = self.reset(os.path.join(listed.directory, "mobile.yaml"))
        self.assertTrue(response.success, response.message)
        self.assertIn("tree", response.message)
        self.assertEqual(len(self.fresh_state().positions), 11)

    def test_bad_scene_files_are_refused_naming_file_and_key(self):
        before = self.fresh_state()
        with tempfile.TemporaryDirectory() as folder:
            cases = (
                ("particles:\n  - {mass: 1.0, colour: red}\n", "particles[0].colour"),
                ("particles:\n  - {mass: -2}\n", "particles[0].mass"),
                ("chains:\n  - {particles: 5000}\n", "max_particles"),
                ("particles: [{mass: 1}]\nforces:\n  - {type: magnetism}\n", "forces[0].type"),
                ("particles: [{mass: 1\n", "not valid YAML"))
            for index, (text, field) in enumerate(cases):
                path = os.path.join(folder, f"bad_{index}.yaml")
                with open(path, "w") as f:
                    f.write(text)
                response = self.reset(path)
                self.assert_refused(response, field)
                if field != "max_particles":
                    self.assertIn(path, response.message)
                self.assert_unchanged(before)
        self.assert_refused(self.reset("/no/such/scene.yaml"), "no such scene file")
        self.assert_unchanged(before)

    def test_changes_belong_to_the_current_scene(self):
        # ~set_chain changes the current scene; ~reset("") keeps it, a name reloads the file
        self.assertTrue(self.set_chain(8, 0.25, 1.0, True).success)
        self.assertTrue(self.reset("").success)
        self.assertEqual(len(self.fresh_state().positions), 8)
        self.assertTrue(self.reset("surface_chain").success)
        self.assertEqual(len(self.fresh_state().positions), 5)
        # a scene without a chain or surface refuses the change and stays as it was
        self.assertTrue(self.reset("bead").success)
        before = self.fresh_state()
        self.assert_refused(self.set_chain(8, 0.25, 1.0, True), "no chain")
        self.assert_unchanged(before)
        self.assertTrue(self.reset("chain").success)
        before = self.fresh_state()
        self.assert_refused(self.set_surface(type="bowl", coefficients=[1.0], expression=""), "no surface")
        self.assert_unchanged(before)

    # --- ~set_surface ---

    def test_set_surface(self):
        response = self.set_surface(type="waves", coefficients=[0.3, 2.0, 1.0], expression="")
        self.assertTrue(response.success, response.message)
        state = self.fresh_state()
        x, y, z = positions_of(state)[0]
        self.assertAlmostEqual(z, 0.3 * math.sin(2.0 * x) * math.cos(1.0 * y), places=9)
        before = state
        for kind, coefficients, field in (
                ("cone", [], "type"),
                ("bowl", [NAN], "coefficients[0]"),
                ("bowl", [1.0, INF], "coefficients[1]"),
                ("bowl", [-1.0], "coefficients[0]"),
                ("gaussian", [1.0, 0.0], "coefficients[1] (width)"),
                ("plane", [1.0, 2.0, 3.0, 4.0], "coefficients")):
            self.assert_refused(self.set_surface(type=kind, coefficients=coefficients, expression=""), field)
            self.assert_unchanged(before)

    def test_set_surface_expression(self):
        response = self.set_surface(type="expression", coefficients=[], expression="0.3*sin(2*x)*cos(y)")
        self.assertTrue(response.success, response.message)
        x, y, z = positions_of(self.fresh_state())[0]
        self.assertAlmostEqual(z, 0.3 * math.sin(2.0 * x) * math.cos(y), places=9)
        before = self.fresh_state()
        refused = self.set_surface(type="expression", coefficients=[], expression="0.3*sin(2*x")
        self.assert_refused(refused, "expression")
        self.assertIn("position 12", refused.message)
        self.assert_unchanged(before)
        self.assert_refused(self.set_surface(type="bowl", coefficients=[1.0], expression="x*y"), "expression")
        self.assert_unchanged(before)

    # --- ~set_chain ---

    def test_set_chain(self):
        response = self.set_chain(7, 0.3, 2.0, True)
        self.assertTrue(response.success, response.message)
        state = self.fresh_state()
        positions = positions_of(state)
        self.assertEqual(len(positions), 7)
        for a, b in zip(positions, positions[1:]):
            self.assertAlmostEqual(distance(a, b), 0.3, places=9)
        before = state
        for request, field in (
                ((0, 0.5, 1.0, True), "num_particles"),
                ((5000, 0.5, 1.0, True), "num_particles"),
                ((2**32 - 1, 0.5, 1.0, True), "num_particles"),
                ((5, 0.0, 1.0, True), "link_length"),
                ((5, -1.0, 1.0, True), "link_length"),
                ((5, NAN, 1.0, True), "link_length"),
                ((5, 0.5, 0.0, True), "particle_mass"),
                ((5, 0.5, -3.0, True), "particle_mass"),
                ((5, 0.5, INF, True), "particle_mass")):
            self.assert_refused(self.set_chain(*request), field)
            self.assert_unchanged(before)

    # --- ~set_state ---

    def test_set_state(self):
        state = self.fresh_state()
        moved = [Point(p.x + 0.01, p.y - 0.02, p.z + 0.015) for p in state.positions]
        response = self.set_state(moved, [])
        self.assertTrue(response.success, response.message)
        self.assertGreater(response.max_displacement, 0.0)
        self.assertLess(response.max_displacement, 0.1)
        after = self.fresh_state()
        self.assertLess(after.max_position_error, 1e-9)
        self.assertEqual(after.sim_time, state.sim_time)
        for v in after.velocities:
            self.assertEqual((v.x, v.y, v.z), (0.0, 0.0, 0.0))
        before = after
        good = list(before.positions)
        bad_nan = list(good)
        bad_nan[2] = Point(NAN, 0.0, 0.0)
        for positions, velocities, field in (
                (good[:-1], [], "positions"),
                (good + [Point()], [], "positions"),
                (good, [Vector3()], "velocities"),
                (bad_nan, [], "positions[2].x"),
                (good, [Vector3(0.0, INF, 0.0)] * len(good), "velocities[0].y")):
            self.assert_refused(self.set_state(positions, velocities), field)
            self.assert_unchanged(before)

    # --- ~pause, ~unpause, ~step ---

    def test_pause_and_step_are_deterministic(self):
        runs = []
        for _ in range(2):
            self.assertTrue(self.reset("").success)
            response = self.step(250)
            self.assertTrue(response.success, response.message)
            self.assertAlmostEqual(response.sim_time, 0.25, places=12)
            state = self.fresh_state()
            self.assertEqual(state.steps, 250)
            runs.append(state)
        self.assertEqual(positions_of(runs[0]), positions_of(runs[1]))
        self.assertEqual([(v.x, v.y, v.z) for v in runs[0].velocities],
                         [(v.x, v.y, v.z) for v in runs[1].velocities])
        # paused: time stands still (over at least 10 more publications: 0.2 s at 50 Hz)
        count = self.states_received
        self.wait_until(lambda: self.states_received >= count + 10, "10 more ~state messages")
        self.assertEqual(self.fresh_state().steps, 250)
        self.assert_refused(self.step(0), "steps")
        self.assert_refused(self.step(10**7), "steps")
        self.unpause()
        self.assert_refused(self.step(10), "pause")

    # --- markers ---

    def test_constraint_force_markers_match_state(self):
        state = self.fresh_state()
        # markers of the same publish tick or later (paused: identical content)
        deadline = time.monotonic() + WAIT
        while time.monotonic() < deadline and not (
                self.latest_forces and self.latest_forces.markers
                and self.latest_forces.markers[0].header.stamp >= state.header.stamp):
            time.sleep(0.01)
        self.assertIsNotNone(self.latest_forces)
        self.assertGreaterEqual(self.latest_forces.markers[0].header.stamp, state.header.stamp)
        scale = rospy.get_param(f"{NODE}/force_scale")
        if scale == 0.0:
            # scaled to the scene: the largest arrow is 0.15 of its region's radius (~view)
            view = rospy.wait_for_message(f"{NODE}/view", SceneView, timeout=WAIT)
            largest = max(math.sqrt(f.x ** 2 + f.y ** 2 + f.z ** 2)
                          for f in state.constraint_forces)
            # forces below 1e-3 of the weight (5 kg here) are not blown up
            scale = 0.15 * view.radius / max(largest, 1e-3 * 5.0 * 9.81)
        arrows = [m for m in self.latest_forces.markers
                  if m.ns == "constraint_forces" and m.action == Marker.ADD]
        self.assertEqual(len(arrows), len(state.positions))
        for marker in arrows:
            self.assertEqual(marker.type, Marker.ARROW)
            force = state.constraint_forces[marker.id]
            start, end = marker.points
            self.assertAlmostEqual(start.x, state.positions[marker.id].x, places=12)
            for axis in ("x", "y", "z"):
                drawn = (getattr(end, axis) - getattr(start, axis)) / scale
                self.assertAlmostEqual(drawn, getattr(force, axis), places=6)
        # fewer particles: the stale arrows are deleted
        type(self).deleted_arrows = set()
        self.assertTrue(self.set_chain(3, 0.5, 1.0, True).success)
        deadline = time.monotonic() + WAIT
        while time.monotonic() < deadline and not {3, 4} <= self.deleted_arrows:
            time.sleep(0.01)
        # the stale ones (and those of a shrink in the last second: the node repeats deletes,
        # rviz keeps only the newest array), never a live one
        self.assertLessEqual({3, 4}, self.deleted_arrows)
        self.assertGreaterEqual(min(self.deleted_arrows), 3)

    def test_scene_markers(self):
        # a message published before setUp's reset may still be in flight: wait for a newer one
        start = rospy.Time.now()
        deadline = time.monotonic() + WAIT
        while time.monotonic() < deadline and not (
                self.latest_scene and self.latest_scene.markers
                and self.latest_scene.markers[0].header.stamp >= start):
            time.sleep(0.01)
        self.assertIsNotNone(self.latest_scene)
        self.assertGreaterEqual(self.latest_scene.markers[0].header.stamp, start)
        by_ns = {m.ns: m for m in self.latest_scene.markers}
        self.assertEqual(by_ns["particles"].type, Marker.SPHERE_LIST)
        self.assertEqual(len(by_ns["particles"].points), 5)
        self.assertEqual(by_ns["links"].type, Marker.LINE_LIST)
        self.assertEqual(len(by_ns["links"].points), 8)
        self.assertNotIn("surface", by_ns)  # on ~surface, once per scene
        surface = rospy.wait_for_message(f"{NODE}/surface", MarkerArray, timeout=WAIT).markers[0]
        self.assertEqual(surface.type, Marker.TRIANGLE_LIST)
        self.assertGreater(len(surface.points), 0)
        self.assertEqual(len(surface.points) % 3, 0)

    # --- dynamic_reconfigure ---

    def test_reconfigure_dt_and_integrator(self):
        client = dynamic_reconfigure.client.Client(NODE, timeout=60.0)
        try:
            config = client.update_configuration({"dt": 0.002, "integrator": "semi_implicit_euler"})
            self.assertAlmostEqual(config["dt"], 0.002)
            self.assertTrue(self.reset("").success)
            response = self.step(100)
            self.assertAlmostEqual(response.sim_time, 0.2, places=12)
        finally:
            client.update_configuration({"dt": 0.001, "integrator": "rk4"})

    def test_state_names_the_stage_path_and_why(self):
        # surface_chain is a chain whose first particle slides on the bowl: the fused chain sweeps;
        # Baumgarte's bias keeps it on the generic stages, and ~state and /diagnostics say so
        client = dynamic_reconfigure.client.Client(NODE, timeout=60.0)
        reports = []
        listener = rospy.Subscriber("/diagnostics", DiagnosticArray, reports.append)

        def path_reported(prefix):
            return any(v.key == "forward path" and v.value.startswith(prefix)
                       for r in reports for s in r.status if s.name.endswith("physics")
                       for v in s.values)
        try:
            state = self.fresh_state()
            self.assertEqual(state.forward_path, "fused_chain")
            self.assertIn("form a chain", state.forward_path_reason)
            self.assertIn("1 on surfaces", state.forward_path_reason)
            self.wait_until(lambda: path_reported("fused_chain: "), "the path on /diagnostics")
            client.update_configuration({"stabilization": "baumgarte"})
            state = self.wait_until(
                lambda: self.latest_state if self.latest_state is not None and
                self.latest_state.forward_path == "generic" else None,
                "~state on the generic stages after the change to Baumgarte")
            self.assertIn("baumgarte", state.forward_path_reason)
            self.wait_until(lambda: path_reported("generic: stabilization = baumgarte"),
                            "the generic path on /diagnostics")
        finally:
            listener.unregister()
            client.update_configuration({"stabilization": "projection"})

    def test_an_overdrawn_energy_budget_hands_the_run_to_the_fallback(self):
        # explicit Euler gains energy on the default chain until about t = 2.14 s: the node goes
        # on with fast_projection, says so in ~state and at WARN on /diagnostics, and keeps it
        # through a reconfigure that leaves the step settings alone
        client = dynamic_reconfigure.client.Client(NODE, timeout=60.0)
        reports = []
        listener = rospy.Subscriber("/diagnostics", DiagnosticArray, reports.append)

        def warned_since(count):
            return any(s.level == DiagnosticStatus.WARN and "energy budget overdrawn" in s.message
                       for r in reports[count:] for s in r.status if s.name.endswith("physics"))
        try:
            client.update_configuration({"integrator": "explicit_euler"})
            self.assertTrue(self.reset("chain").success)
            response = self.step(3000)
            self.assertTrue(response.success, response.message)
            state = self.wait_until(
                lambda: self.latest_state if self.latest_state is not None and
                self.latest_state.sim_time >= 2.9 else None,
                "the ~state after 3,000 steps")
            self.assertTrue(state.energy_fallback)
            self.assertNotEqual(state.status, SimState.STATUS_FAULT, state.status_message)
            self.wait_until(lambda: warned_since(0), "the fallback's WARN on /diagnostics")
            seen = len(reports)
            client.update_configuration({"publish_rate": 40.0})
            self.wait_until(lambda: warned_since(seen), "the WARN after a reconfigure")
            self.assertTrue(self.reset("").success)
            self.assertFalse(self.fresh_state().energy_fallback)
        finally:
            listener.unregister()
            client.update_configuration({"integrator": "rk4", "publish_rate": 50.0})


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "simulator_interface", SimulatorInterfaceTest)
