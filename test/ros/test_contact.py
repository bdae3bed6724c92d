#!/usr/bin/python3
"""Contact through the node (issue 35): surface_chain_contact for 10 s keeps every particle on or
above the bowl and its links exact, with no fault, ~state naming the touching particles; a rope
slides off its table without going into it. Waits are wall-clock deadlines with polling."""
import math
import unittest

import rospy
import rostest
from topic_recorder import Recorder
from wall_clock import WallClockWaits
from constrained_particles.msg import SimState
from constrained_particles.srv import Reset, Step
from std_srvs.srv import Empty
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

    def run_scene(self, scenario, surface, seconds, link=None):
        """Steps `scenario` `seconds` in chunks of 0.1 s, checking the state after each: no
        particle below `surface` by more than TOLERANCE, links of `link` [m] exact to it, no
        fault. Returns the last state."""
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
            if link is not None:
                for a, b in zip(state.positions, state.positions[1:]):
                    length = math.dist((a.x, a.y, a.z), (b.x, b.y, b.z))
                    self.assertLessEqual(abs(length - link), TOLERANCE, f"t = {t}")
            self.assertLessEqual(state.max_position_error, TOLERANCE, f"t = {t}")
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


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "contact", ContactTest)
