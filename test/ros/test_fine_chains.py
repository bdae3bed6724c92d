#!/usr/bin/python3
"""Fine-link chains through the node (issue 14): 10 s without a fault at default settings, the
sub-steps shown on ~state; with ~max_substeps = 1 a step check faults the node as before.
Waits are wall-clock deadlines with polling."""
import threading
import unittest

import rospy
import rostest
from wall_clock import WallClockWaits
from constrained_particles.msg import SimState
from constrained_particles.srv import Reset, SetChain, SetChainRequest, Step
from dynamic_reconfigure.client import Client
from std_srvs.srv import Empty

NODE = "/simulator"


class FineChainsTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("fine_chains_test")
        for name in ("pause", "step", "set_chain", "reset"):
            rospy.wait_for_service(f"{NODE}/{name}", timeout=60.0)
        cls.pause = rospy.ServiceProxy(f"{NODE}/pause", Empty)
        cls.step = rospy.ServiceProxy(f"{NODE}/step", Step)
        cls.set_chain = rospy.ServiceProxy(f"{NODE}/set_chain", SetChain)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        cls.client = Client(NODE, timeout=60.0)
        cls.lock = threading.Lock()
        cls.states = []
        rospy.Subscriber(f"{NODE}/state", SimState, cls.store, queue_size=1000)

    @classmethod
    def store(cls, message):
        with cls.lock:
            cls.states.append(message)

    def states_since(self, count):
        with self.lock:
            return list(self.states[count:])

    def fine_chain(self, n):
        """Paused at t = 0 on a pinned chain of n particles, 1 cm links, 10 g."""
        self.pause()
        reply = self.set_chain(num_particles=n, link_length=0.01, particle_mass=0.01,
                               pin_first=SetChainRequest.PIN_FIRST_PIN)
        self.assertTrue(reply.success, reply.message)
        self.assertTrue(self.reset().success)
        with self.lock:
            count = len(self.states)
        self.wait_until(lambda: any(len(s.positions) == n and s.sim_time == 0.0
                                    for s in self.states_since(count)),
                        f"~state of the {n}-particle chain at t = 0")

    def run_ten_seconds(self, n):
        self.fine_chain(n)
        with self.lock:
            count = len(self.states)
        reply = self.step(10000)
        return reply, count

    def test_a_fine_chains_run_ten_seconds_with_substeps(self):
        self.client.update_configuration({"max_substeps": 1024})
        for n in (200, 1000):
            reply, count = self.run_ten_seconds(n)
            self.assertTrue(reply.success, reply.message)
            self.assertEqual(reply.steps_taken, 10000)
            self.assertAlmostEqual(reply.sim_time, 10.0, places=6)
            last = self.wait_until(
                lambda: next((s for s in reversed(self.states_since(count))
                              if abs(s.sim_time - 10.0) < 1e-6), None),
                "~state at t = 10 s")
            self.assertNotEqual(last.status, SimState.STATUS_FAULT, last.status_message)
            self.assertLessEqual(last.max_position_error, 1e-9)
            seen = [s for s in self.states_since(count) if len(s.positions) == n]
            steps = sum(s.interval_steps for s in seen)
            substeps = sum(s.substeps for s in seen)
            self.assertGreaterEqual(steps, 10000, "every step reported")
            self.assertGreater(substeps, steps, f"n = {n}: no step was split")
            self.assertGreater(max(s.max_substeps_per_step for s in seen), 1)
            self.assertGreater(max(s.max_frequency for s in seen), 1000.0)

    def test_b_max_substeps_one_faults_as_before(self):
        self.client.update_configuration({"max_substeps": 1})
        try:
            reply, count = self.run_ten_seconds(200)
            self.assertFalse(reply.success)
            self.assertIn("step check", reply.message)
            self.assertIn("~max_substeps = 1", reply.message)
            self.assertLess(reply.sim_time, 2.5)  # the issue measured non-finite at 1.96 s
            fault = self.wait_until(
                lambda: next((s for s in self.states_since(count)
                              if s.status == SimState.STATUS_FAULT), None), "FAULT on ~state")
            self.assertIn("step check", fault.status_message)
            seen = [s for s in self.states_since(count) if len(s.positions) == 200]
            self.assertTrue(all(s.max_substeps_per_step <= 1 for s in seen))
            self.assertEqual(sum(s.rejected_steps for s in seen), 0)
        finally:
            self.client.update_configuration({"max_substeps": 1024})


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "fine_chains", FineChainsTest)
