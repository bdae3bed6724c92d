#!/usr/bin/python3
"""10,000 random and adversarial service requests, interleaved with valid ones.

Every request is built knowing whether it is valid: valid ones must be accepted, invalid ones
refused with a message naming what is wrong. Afterwards the node must be alive and publish a
finite state that satisfies its constraints.
"""
import math
import os
import random
import re
import tempfile
import time
import unittest

import rospy
import rostest
import yaml
from wall_clock import WallClockWaits
from constrained_particles.msg import SimState
from constrained_particles.srv import (ApplyForce, ClearForces, ListScenes, Reset, SetChain,
                                       SetObstacle, SetObstacleRequest, SetState, SetSurface,
                                       Step)
from dynamic_reconfigure.msg import Config, DoubleParameter, StrParameter
from dynamic_reconfigure.srv import Reconfigure
from geometry_msgs.msg import Point, Vector3
from std_srvs.srv import Empty

NODE = "/simulator"
CALLS = 10000
SEED = 20261122
MAX_PARTICLES = 500  # as fuzz_services.test sets ~max_particles
NAN, INF = float("nan"), float("inf")
BAD_LINKS = [NAN, INF, -INF, -1.0, 0.0, 1e4, 1e300, -1e300]        # valid: [1e-06, 1000] m
BAD_MASSES = [NAN, INF, -INF, -1.0, 0.0, 1e7, 1e300]               # valid: [1e-09, 1e+06] kg
BAD_COUNTS = [0, MAX_PARTICLES + 1, 10**6, 2**32 - 1]             # valid: [1, max_particles]
SURFACE_TYPES = {"plane": 3, "bowl": 2, "saddle": 2, "waves": 3, "gaussian": 4}
# scenes with chains and their particles per chain; those naming chain particles by index keep
# their counts (config/scenes)
CHAIN_COUNTS = {"chain": 5, "surface_chain": 5, "pinned_pendulum": 4, "two_chains_on_surface": 4,
                "mobile": 3, "shaken_chain": 6, "stiff_rod": 4, "hold_the_rope": 8,
                "surface_chain_contact": 5, "friction_ramp": 4, "rope_on_table": 20,
                "rope_over_post": 30, "rope_over_edge": 20, "rope_pile": 30, "cable": 10}
# scenes with a surface_contact or shape_contact: a chain or surface change that would start a
# particle below the surface or inside an obstacle, or a teleport that would put one there, is
# refused, naming the particle (a request
# valid field by field may be)
CONTACT_SCENES = {"surface_chain_contact", "friction_ramp", "rope_on_table", "dome",
                  "rope_over_post", "rope_over_edge", "rope_pile"}


def contact_refusal(scene, expect, response):
    """A request valid field by field that a contact scene refused for where a particle would
    start (the message says so): then not valid, and its refusal counts as one."""
    return expect and scene in CONTACT_SCENES and not response.success and \
        ("below surface" in response.message or "inside obstacle" in response.message)
FIXED_COUNT = {"two_chains_on_surface", "mobile", "shaken_chain", "stiff_rod", "hold_the_rope",
               "cable"}
# pinning these chains' first particles over-constrains them (the hub; the driven or held top):
# refused
NO_PIN_FIRST = {"mobile", "shaken_chain", "hold_the_rope"}


def scenes_with_a_surface(directory):
    """The scenes in `directory` whose files declare surfaces (read, so a new scene counts)."""
    names = set()
    for entry in os.listdir(directory):
        if entry.endswith(".yaml"):
            with open(os.path.join(directory, entry)) as f:
                if (yaml.safe_load(f) or {}).get("surfaces"):
                    names.add(entry[:-len(".yaml")])
    return names


class Tally:
    def __init__(self):
        self.calls = 0
        self.valid = 0
        self.invalid = 0
        self.problems = []
        self.by_service = {}

    def record(self, service, valid, accepted, message):
        self.calls += 1
        counts = self.by_service.setdefault(service, [0, 0])
        counts[0 if valid else 1] += 1
        if valid:
            self.valid += 1
            if accepted is False:
                self.problems.append(f"{service}: valid request refused: {message}")
        else:
            self.invalid += 1
            if accepted:
                self.problems.append(f"{service}: invalid request accepted: {message}")
            elif not message:
                self.problems.append(f"{service}: refused without a message")


class FuzzServicesTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("fuzz_services_test")
        for name in ("reset", "list_scenes", "set_surface", "set_chain", "set_state", "pause",
                     "unpause", "step", "set_parameters", "apply_force", "clear_forces"):
            rospy.wait_for_service(f"{NODE}/{name}", timeout=60.0)

        def proxy(name, kind):
            return rospy.ServiceProxy(f"{NODE}/{name}", kind, persistent=True)

        cls.reset = proxy("reset", Reset)
        cls.list_scenes = proxy("list_scenes", ListScenes)
        cls.set_surface = proxy("set_surface", SetSurface)
        cls.set_chain = proxy("set_chain", SetChain)
        cls.set_state = proxy("set_state", SetState)
        cls.pause = proxy("pause", Empty)
        cls.unpause = proxy("unpause", Empty)
        cls.step = proxy("step", Step)
        cls.reconfigure = proxy("set_parameters", Reconfigure)
        cls.apply_force = proxy("apply_force", ApplyForce)
        cls.clear_forces = proxy("clear_forces", ClearForces)
        cls.set_obstacle = proxy("set_obstacle", SetObstacle)
        cls.latest = None
        rospy.Subscriber(f"{NODE}/state", SimState, cls._on_state, queue_size=1)

    @classmethod
    def _on_state(cls, msg):
        cls.latest = msg


    def fresh_state(self):
        """A ~state published after this call (stamped with wall time at publishing: it shows
        every service call answered before)."""
        start = rospy.Time.now()
        return self.wait_until(
            lambda: self.latest if self.latest is not None and self.latest.header.stamp > start
            else None, "a fresh ~state")

    def test_fuzz_every_service(self):
        rng = random.Random(SEED)
        tally = Tally()
        listing = self.list_scenes()
        scenes = list(listing.names)
        with_surface = scenes_with_a_surface(listing.directory)
        self.assertIn("surface_chain", with_surface)
        folder = tempfile.mkdtemp()
        bad_files = self.write_bad_scene_files(folder, rng)
        self.pause()
        paused = True
        scene = "surface_chain"
        self.assertTrue(self.reset(scene).success)
        particles = 5
        start = time.monotonic()

        chain_count = CHAIN_COUNTS[scene]

        pushes = [0]  # forces ~apply_force started since the scene last changed (at most)

        def reset_to(name):
            nonlocal scene, particles, chain_count
            response = self.reset(name)
            if response.success:
                pushes[0] = 0
                if name:
                    scene = name
                    chain_count = CHAIN_COUNTS.get(name, 0)
                particles = int(re.search(r"\((\d+) particles", response.message).group(1))
            return response

        while tally.calls < CALLS:
            kind = rng.random()
            if kind < 0.14:  # ~reset
                choice = rng.random()
                if choice < 0.4:
                    name = rng.choice(scenes + [""])
                    r = reset_to(name)
                    tally.record("reset", True, r.success, r.message)
                else:
                    name = rng.choice([
                        "pendulum", "CHAIN", "x" * rng.choice([1, 100, 100000]), "../../etc/passwd",
                        "/", folder, "/dev/null", "/dev/zero", "\0", "bead\n", "bead.yaml",
                        "/no/such/scene.yaml"] + bad_files)
                    r = self.reset(name)
                    tally.record("reset", False, r.success, r.message)
            elif kind < 0.26:  # ~set_chain
                request = [rng.randint(1, 40), rng.uniform(0.05, 2.0), rng.uniform(0.1, 10.0),
                           rng.random() < 0.5]
                valid = rng.random() < 0.4
                if scene in FIXED_COUNT and rng.random() < 0.5:
                    request[0] = chain_count
                if scene in NO_PIN_FIRST:
                    # pinning the chains' first particles would over-constrain them: refused as
                    # infeasible, so valid requests leave them free
                    request[3] = False
                if not valid:  # one field out of range
                    field = rng.randrange(3)
                    request[field] = rng.choice([BAD_COUNTS, BAD_LINKS, BAD_MASSES][field])
                expect = valid and scene in CHAIN_COUNTS and (
                    scene not in FIXED_COUNT or request[0] == chain_count)
                r = self.set_chain(*request)
                if contact_refusal(scene, expect, r):
                    expect = False
                tally.record("set_chain", expect, r.success, r.message)
                if r.success:
                    particles = int(re.search(r"\((\d+) particles", r.message).group(1))
                    chain_count = request[0]
                    pushes[0] = 0
            elif kind < 0.38:  # ~set_surface
                choice = rng.random()
                if choice < 0.35:
                    kind_name = rng.choice(list(SURFACE_TYPES))
                    count = rng.randint(0, SURFACE_TYPES[kind_name])
                    coefficients = [rng.uniform(0.0, 1.0) for _ in range(count)]
                    if kind_name == "gaussian" and count >= 2:
                        coefficients[1] = rng.uniform(0.2, 2.0)  # width > 0
                    r = self.set_surface(type=kind_name, coefficients=coefficients, expression="",
                                         keep_state=rng.random() < 0.5)
                    tally.record("set_surface", scene in with_surface and not contact_refusal(
                        scene, True, r), r.success, r.message)
                    if r.success:
                        pushes[0] = 0
                elif choice < 0.5:
                    formula = rng.choice(["0.3*sin(2*x)*cos(y)", "x^2/4 + y^2/4", "0.1*x - 0.2*y",
                                          "tanh(x)*0.2", "exp(-(x^2+y^2))"])
                    r = self.set_surface(type="expression", coefficients=[], expression=formula,
                                         keep_state=rng.random() < 0.5)
                    tally.record("set_surface", scene in with_surface and not contact_refusal(
                        scene, True, r), r.success, r.message)
                    if r.success:
                        pushes[0] = 0
                else:
                    bad = rng.choice([
                        ("cone", [], ""), ("", [], ""), ("bowl", [NAN], ""),
                        ("bowl", [1.0, INF], ""), ("bowl", [-1.0], ""), ("bowl", [1e7], ""),
                        ("plane", [1.0, 2.0, 3.0, 4.0], ""), ("gaussian", [1.0, 0.0], ""),
                        ("bowl", [1.0], "x*y"), ("expression", [], "sin(x"),
                        ("expression", [], ""), ("expression", [], "x" * 5000),
                        ("expression", [], "(" * 2000), ("expression", [1.0], "x"),
                        ("expression", [], "foo(x)"), ("expression", [], "x +* y"),
                        ("expression", [], "1/0*x" + "\0"), ("waves", [1.0] * 100, "")])
                    r = self.set_surface(*bad, rng.random() < 0.5)
                    tally.record("set_surface", False, r.success, r.message)
            elif kind < 0.52:  # ~set_state
                if rng.random() < 0.15 and paused:
                    state = self.fresh_state()
                    if len(state.positions) == particles:
                        moved = [Point(p.x + rng.uniform(-1e-3, 1e-3), p.y + rng.uniform(-1e-3, 1e-3),
                                       p.z + rng.uniform(-1e-3, 1e-3)) for p in state.positions]
                        r = self.set_state(moved, [])
                        # a contact particle moved below its surface is refused, naming it
                        tally.record("set_state", not contact_refusal(scene, True, r), r.success,
                                     r.message)
                        continue
                count = rng.choice([0, particles - 1, particles + 1, particles, 10**4])
                count = max(count, 0)
                positions = [Point(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1))
                             for _ in range(count)]
                velocities = []
                if count == particles:
                    # right length: poison one value
                    target = rng.choice(["position", "velocity"])
                    if count == 0:
                        continue
                    bad = rng.choice([NAN, INF, -INF, 1e300, -1e7])
                    if target == "position":
                        i = rng.randrange(count)
                        positions[i] = Point(bad, positions[i].y, positions[i].z)
                    else:
                        velocities = [Vector3(0.0, 0.0, 0.0) for _ in range(count)]
                        velocities[rng.randrange(count)] = Vector3(0.0, bad, 0.0)
                elif rng.random() < 0.3:
                    velocities = [Vector3()] * (particles + rng.choice([1, 7]))
                    positions = [Point()] * particles
                r = self.set_state(positions, velocities)
                tally.record("set_state", False, r.success, r.message)
            elif kind < 0.66:  # ~step
                if paused and rng.random() < 0.6:
                    r = self.step(rng.randint(1, 50))
                    tally.record("step", True, r.success, r.message)
                else:
                    steps = rng.choice([0, 10**6 + 1, 2**32 - 1]) if paused else rng.randint(1, 10)
                    r = self.step(steps)
                    tally.record("step", False, r.success, r.message)
            elif kind < 0.74:  # ~pause / ~unpause
                if rng.random() < 0.5:
                    self.pause()
                    paused = True
                else:
                    self.unpause()
                    paused = False
                tally.record("pause/unpause", True, None, "")
            elif kind < 0.80:  # ~list_scenes
                names = self.list_scenes().names
                tally.record("list_scenes", True, list(names) == scenes, "names changed")
            elif kind < 0.86:  # ~apply_force, ~clear_forces
                if rng.random() < 0.1 or pushes[0] >= 900:
                    r = self.clear_forces()
                    tally.record("clear_forces", True, r.success, r.message)
                    pushes[0] = 0
                    continue
                request = [rng.randrange(particles), [rng.uniform(-10, 10) for _ in range(3)],
                           rng.choice([0.0, rng.uniform(0.0, 0.05)])]
                valid = rng.random() < 0.5
                if not valid:  # one field out of range
                    field = rng.randrange(3)
                    if field == 0:
                        request[0] = rng.choice([particles, particles + 7, 2**32 - 1])
                    elif field == 1:
                        request[1][rng.randrange(3)] = rng.choice([NAN, INF, -INF, 1e10, -1e300])
                    else:
                        request[2] = rng.choice([-1e-9, -1.0, NAN, INF, 1e7])
                r = self.apply_force(request[0], Vector3(*request[1]), request[2])
                tally.record("apply_force", valid, r.success, r.message)
                if r.success:
                    pushes[0] += 1
            else:  # dynamic_reconfigure's set_parameters
                valid = rng.random() < 0.4
                config = Config()
                if valid:
                    config.doubles = [DoubleParameter("dt", rng.choice([0.0005, 0.001, 0.002]))]
                    config.strs = [StrParameter("integrator", rng.choice(["rk4", "midpoint", "dopri5"]))]
                    applied = self.reconfigure(config).config
                    ok = any(d.name == "dt" and d.value == config.doubles[0].value
                             for d in applied.doubles)
                    tally.record("set_parameters", True, ok, "valid dt not applied")
                else:
                    # out-of-range numbers are clamped to the range by dynamic_reconfigure (its
                    # convention); NaN and unknown names are refused by the node
                    before = self.reconfigure(Config()).config
                    name, value = rng.choice([("dt", NAN), ("gravity_z", NAN), ("damping", NAN),
                                              ("baumgarte_frequency", NAN),
                                              ("integrator", "leapfrog"), ("integrator", ""),
                                              ("stabilization", "magic"),
                                              ("integrator", "x" * 10000)])
                    config = Config()
                    if isinstance(value, str):
                        config.strs = [StrParameter(name, value)]
                    else:
                        config.doubles = [DoubleParameter(name, value)]
                    applied = self.reconfigure(config).config
                    kept = [p.value for p in applied.doubles + applied.strs if p.name == name]
                    old = [p.value for p in before.doubles + before.strs if p.name == name]
                    # a refused reconfiguration answers with the values kept (the reason is logged)
                    tally.record("set_parameters", False, kept != old,
                                 "kept" if kept == old else f"{name} = {value!r} applied")
        elapsed = time.monotonic() - start

        # afterwards: alive, and a finite state on its constraints
        self.pause()
        self.assertTrue(self.reset("surface_chain").success)
        self.assertTrue(self.step(100).success)
        state = self.fresh_state()
        values = [c for p in state.positions for c in (p.x, p.y, p.z)]
        values += [c for v in state.velocities for c in (v.x, v.y, v.z)] + list(state.multipliers)
        self.assertTrue(all(math.isfinite(v) for v in values))
        self.assertLess(state.max_position_error, 1e-8)
        self.assertEqual(state.status, SimState.STATUS_PAUSED)
        summary = (f"fuzz: {tally.calls} calls in {elapsed:.0f} s: {tally.valid} valid "
                   f"(all accepted: {not any('valid request refused' in p for p in tally.problems)}), "
                   f"{tally.invalid} invalid (all refused with a message: "
                   f"{not any('invalid' in p or 'without' in p for p in tally.problems)}); "
                   f"node alive, final state finite, max constraint error "
                   f"{state.max_position_error:.1e} m; by service (valid, invalid): "
                   + ", ".join(f"{k} {v[0]}/{v[1]}" for k, v in sorted(tally.by_service.items())))
        rospy.loginfo(summary)
        if os.environ.get("CP_FUZZ_SUMMARY"):
            with open(os.environ["CP_FUZZ_SUMMARY"], "w") as f:
                f.write(summary + "\n")
        self.assertGreaterEqual(tally.calls, 10000)
        self.assertEqual(len(tally.problems), 0, "\n".join(tally.problems[:20]))

    def test_fuzz_set_obstacle(self):
        """~set_obstacle (issue 48, item 5): 400 requests on rope_over_post between steps, valid
        (the post moved and resized, spheres added near the rope and removed, fixed or carried
        by a frame or topic never sent, where they rest as written) and not (bad operation,
        names, YAML, ranges, holders the node cannot follow): valid ones accepted (but a change
        the projection cannot undo, refused saying so), the rest refused with a message;
        afterwards a finite state on its constraints, outside every obstacle."""
        rng = random.Random(SEED + 1)
        tally = Tally()
        too_deep = [0]

        def record(r):
            """A valid change the projection cannot undo (the rope squeezed between the post and
            the floor) is refused saying so, nothing changed: not valid, as contact_refusal's."""
            deep = not r.success and "too deep for the projection" in r.message
            too_deep[0] += deep
            tally.record("set_obstacle", not deep, r.success, r.message)
        self.pause()
        # the default method: the other test leaves whatever its fuzz set last (dopri5 takes
        # minutes for 50 steps of this rope's friction: its error control meets every stick)
        config = Config()
        config.doubles = [DoubleParameter("dt", 0.001)]
        config.strs = [StrParameter("integrator", "rk4")]
        self.reconfigure(config)
        self.assertTrue(self.reset("rope_over_post").success)
        added = []
        post = [0.0, 0.5, 0.05]  # x, z, radius [m]

        def cylinder(x, z, radius):
            return (f"{{type: cylinder, position: [{x}, 0, {z}], "
                    f"rpy: [1.5707963267948966, 0, 0], radius: {radius}, length: 0.8}}")

        while tally.calls < 400:
            kind = rng.random()
            if kind < 0.3:  # the post moved by up to 2 cm and resized within 3-8 cm
                moved = [post[0] + rng.uniform(-0.02, 0.02), post[1] + rng.uniform(-0.02, 0.02),
                         rng.uniform(0.03, 0.08)]
                r = self.set_obstacle(operation=SetObstacleRequest.REPLACE, name="post",
                                      shape=cylinder(*moved))
                record(r)
                if r.success:
                    post = moved
            elif kind < 0.45:  # a small sphere near the rope, a third of them on a holder
                name = f"ball_{tally.calls}"
                holder = rng.choice(["", ", frame: fuzz_hand", ", topic: fuzz_pose"])
                shape = (f"{{type: sphere, position: [{rng.uniform(-0.6, 0.6)}, 0, "
                         f"{rng.uniform(0.1, 0.7)}], radius: {rng.uniform(0.01, 0.04)}{holder}}}")
                r = self.set_obstacle(operation=SetObstacleRequest.ADD, name=name, shape=shape)
                record(r)
                if r.success:
                    added.append(name)
            elif kind < 0.55 and added:
                name = added.pop(rng.randrange(len(added)))
                r = self.set_obstacle(operation=SetObstacleRequest.REMOVE, name=name, shape="")
                record(r)
            elif kind < 0.7:
                r = self.step(rng.randint(1, 50))
                self.assertTrue(r.success, r.message)
            else:
                operation, name, shape = rng.choice([
                    (3, "post", ""), (255, "post", cylinder(0, 0.5, 0.05)),
                    (SetObstacleRequest.ADD, "", "{type: sphere}"),
                    (SetObstacleRequest.ADD, "post", "{type: sphere}"),
                    (SetObstacleRequest.ADD, "floor", "{type: sphere}"),
                    (SetObstacleRequest.ADD, "b", "{type: sphere, radius: -1}"),
                    (SetObstacleRequest.ADD, "b", "{type: sphere, radius: .nan}"),
                    (SetObstacleRequest.ADD, "b", "{type: sphere, position: [1e9, 0, 0]}"),
                    (SetObstacleRequest.ADD, "b", "{type: torus}"),
                    (SetObstacleRequest.ADD, "b", "{radius: 0.1}"),
                    (SetObstacleRequest.ADD, "b", ""),
                    (SetObstacleRequest.ADD, "b", "[1, 2, 3]"),
                    (SetObstacleRequest.ADD, "b", "{type: sphere, radius: ["),
                    (SetObstacleRequest.ADD, "b", "{type: sphere, frame: /tool0}"),
                    (SetObstacleRequest.ADD, "b", "{type: sphere, frame: particle_2}"),
                    (SetObstacleRequest.ADD, "b", "{type: sphere, topic: 'bad topic'}"),
                    (SetObstacleRequest.ADD, "b", "{type: box, size: [1, 1, 1e9]}"),
                    (SetObstacleRequest.ADD, "b", "{type: sphere, colour: red}"),
                    (SetObstacleRequest.ADD, "b", "x" * 100000),
                    (SetObstacleRequest.REPLACE, "pole", cylinder(0, 0.5, 0.05)),
                    (SetObstacleRequest.REPLACE, "post", "{type: cylinder, length: 0}"),
                    (SetObstacleRequest.REMOVE, "pole", ""),
                    (SetObstacleRequest.REMOVE, "post", "{type: sphere}"),
                    (SetObstacleRequest.REMOVE, "\0", "")])
                r = self.set_obstacle(operation=operation, name=name, shape=shape)
                tally.record("set_obstacle", False, r.success, r.message)
        self.assertTrue(self.step(100).success)
        state = self.fresh_state()
        values = [c for p in state.positions for c in (p.x, p.y, p.z)]
        values += [c for v in state.velocities for c in (v.x, v.y, v.z)]
        self.assertTrue(all(math.isfinite(v) for v in values))
        self.assertLess(state.max_position_error, 1e-8)
        for i, p in enumerate(state.positions):
            gap = math.hypot(p.x - post[0], p.z - post[1]) - post[2] - 0.01
            self.assertGreaterEqual(gap, -1e-8, f"particle {i} inside the post")
            self.assertGreaterEqual(p.z, 0.01 - 1e-8, f"particle {i} in the floor")
        rospy.loginfo("fuzz set_obstacle: %d calls, %d valid, %d invalid (%d of them too deep to "
                      "undo); %d spheres left", tally.calls, tally.valid, tally.invalid,
                      too_deep[0], len(added))
        self.assertEqual(len(tally.problems), 0, "\n".join(tally.problems[:20]))
        self.assertGreaterEqual(tally.valid, 200)  # the refusals for depth are the exception

    @staticmethod
    def write_bad_scene_files(folder, rng):
        texts = [
            "particles:\n  - {mass: 1.0, colour: red}\n",
            "chains:\n  - {particles: 100000}\n",  # over ~max_particles
            "particles: [{mass: 1}]\nforces:\n  - {type: magnetism}\n",
            "particles: [{mass: 1\n",
            "[1, 2, 3]\n",
            "particles: [{mass: .nan}]\n",
            "particles: [{mass: 1}, {mass: 1}]\nconstraints:\n  - {type: link, first: 0, second: 9}\n",
            "a: &a [*a]\n",
            "x" * (2 << 20),  # over the file size limit
            bytes(rng.getrandbits(8) for _ in range(2000)).decode("latin-1"),
        ]
        paths = []
        for index, text in enumerate(texts):
            path = os.path.join(folder, f"bad_{index}.yaml")
            with open(path, "w", encoding="latin-1") as f:
                f.write(text)
            paths.append(path)
        return paths


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "fuzz_services", FuzzServicesTest)
