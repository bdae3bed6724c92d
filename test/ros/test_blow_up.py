#!/usr/bin/python3
"""A blow-up is contained: FAULT on ~state and /diagnostics, nothing non-finite published."""
import math
import time
import unittest

import rospy
import rostest
from wall_clock import WallClockWaits
from constrained_particles.msg import SimState
from constrained_particles.srv import Reset
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

NODE = "/simulator"


def finite(values):
    return all(math.isfinite(v) for v in values)


class BlowUpTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("blow_up_test")
        rospy.wait_for_service(f"{NODE}/reset", timeout=60.0)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        cls.states, cls.transforms, cls.markers, cls.diagnostics = [], [], [], []
        rospy.Subscriber(f"{NODE}/state", SimState, cls.states.append)
        rospy.Subscriber("/tf", TFMessage, cls.transforms.append)
        rospy.Subscriber(f"{NODE}/constraint_forces", MarkerArray, cls.markers.append)
        rospy.Subscriber("/diagnostics", DiagnosticArray, cls.diagnostics.append)


    def latest_state(self):
        count = len(self.states)
        self.wait_until(lambda: len(self.states) > count, "new ~state", 30.0)
        return self.states[-1]

    def first_state_after(self, start):
        """The first ~state stamped after `start` (stamped with wall time at publishing: such a
        state shows every service call answered before `start`)."""
        return self.wait_until(lambda: next((s for s in list(self.states) if s.header.stamp > start),
                                          None), "~state published after the call", 30.0)

    def test_fault_is_contained_and_reset_recovers(self):
        limit = rospy.get_param(f"{NODE}/max_constraint_error")
        fault = self.wait_until(
            lambda: next((s for s in self.states if s.status == SimState.STATUS_FAULT), None),
            "FAULT status", 60.0)
        self.assertTrue("constraint error" in fault.status_message or
                        "step check" in fault.status_message or
                        "non-finite" in fault.status_message, fault.status_message)
        self.assertIn("~reset", fault.status_message)

        # stepping stopped, at a good state: compare across at least 10 further publications
        # (0.5 s at 20 Hz), however slowly they come
        first = self.latest_state()
        count = len(self.states)
        self.wait_until(lambda: len(self.states) >= count + 10, "10 more ~state messages", 30.0)
        second = self.latest_state()
        self.assertEqual(first.status, SimState.STATUS_FAULT)
        self.assertEqual(first.steps, second.steps)
        self.assertEqual(first.sim_time, second.sim_time)
        self.assertLessEqual(second.max_position_error, limit)

        # nothing non-finite in anything published, before or after the fault
        for s in list(self.states):
            self.assertTrue(finite([c for p in s.positions for c in (p.x, p.y, p.z)]))
            self.assertTrue(finite([c for v in s.velocities for c in (v.x, v.y, v.z)]))
            self.assertTrue(finite([c for f in s.constraint_forces for c in (f.x, f.y, f.z)]))
            self.assertTrue(finite(list(s.multipliers) + [s.max_position_error, s.max_velocity_error,
                                                           s.kinetic_energy, s.potential_energy]))
        for message in list(self.transforms):
            for t in message.transforms:
                v = t.transform.translation
                self.assertTrue(finite([v.x, v.y, v.z]), t.child_frame_id)
        for array in list(self.markers):
            for m in array.markers:
                self.assertTrue(finite([c for p in m.points for c in (p.x, p.y, p.z)]))

        # /diagnostics says ERROR
        errors = self.wait_until(
            lambda: [st for a in self.diagnostics for st in a.status
                     if st.name.endswith("simulator: physics") and st.level == DiagnosticStatus.ERROR],
            "ERROR on /diagnostics", 30.0)
        self.assertIn("~reset", errors[-1].message)

        # ~reset recovers; the first state after the reset, not one already in flight (nor one
        # after the chain, running again, blew up again)
        response = self.reset("")
        self.assertTrue(response.success, response.message)
        recovered = self.first_state_after(rospy.Time.now())
        self.assertNotEqual(recovered.status, SimState.STATUS_FAULT)
        self.assertLess(recovered.steps, fault.steps)
        later = self.latest_state()
        self.assertGreaterEqual(later.steps, recovered.steps)


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "blow_up", BlowUpTest)
