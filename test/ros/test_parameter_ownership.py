#!/usr/bin/python3
"""Start-up reads only what the user set. Three nodes run one after another on one master under
one name: the first is reconfigured (dt, integrator, damping); the next ones, started with other
scenes and no step parameters, run their own scene's solver settings and forces. Waits are
wall-clock deadlines with polling."""
import os
import subprocess
import time
import unittest

import rospy
import rostest
from wall_clock import interrupt
import yaml
from dynamic_reconfigure.client import Client

NAME = "simulator"
SCENES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "config", "scenes")


def scene_solver(name):
    with open(os.path.join(SCENES, name + ".yaml")) as f:
        return yaml.safe_load(f).get("solver", {}) or {}


def scene_damping(name):
    with open(os.path.join(SCENES, name + ".yaml")) as f:
        forces = yaml.safe_load(f).get("forces", []) or []
    return sum(f.get("coefficient", 0.0) for f in forces if f.get("type") == "linear_damping")


class ParameterOwnershipTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("parameter_ownership_test")

    def start(self, scenario):
        node = subprocess.Popen(
            ["rosrun", "constrained_particles", "simulator_node", f"__name:={NAME}",
             f"_scenario:={scenario}"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        self.addCleanup(interrupt, node)
        rospy.wait_for_service(f"/{NAME}/set_parameters", timeout=120.0)
        return node, Client(f"/{NAME}", timeout=120.0)


    def wait_gone(self):
        deadline = time.monotonic() + 60.0
        while self.service_up():
            if time.monotonic() > deadline:
                self.fail("the previous node did not leave the master")
            time.sleep(0.1)

    @staticmethod
    def service_up():
        try:
            rospy.wait_for_service(f"/{NAME}/set_parameters", timeout=0.1)
            return True
        except rospy.ROSException:
            return False

    def expect_scene_settings(self, client, scenario):
        config = client.get_configuration(timeout=60.0)
        solver = scene_solver(scenario)
        self.assertEqual(config["integrator"], solver.get("integrator", "rk4"), scenario)
        self.assertAlmostEqual(config["dt"], solver.get("dt", 0.001), places=12, msg=scenario)
        self.assertAlmostEqual(config["damping"], scene_damping(scenario), places=12, msg=scenario)

    def test_next_start_runs_its_own_scene(self):
        first, client = self.start("chain")
        self.expect_scene_settings(client, "chain")
        # the reply is the configuration in force (get_configuration may still hold the last one)
        in_force = client.update_configuration({"dt": 0.002, "integrator": "semi_implicit_euler",
                                                "damping": 0.7})
        self.assertEqual(in_force["integrator"], "semi_implicit_euler")
        self.assertAlmostEqual(in_force["damping"], 0.7, places=12)
        # the node keeps its run-time state to itself: no ~dt left behind for the next start
        for key in ("dt", "integrator", "damping", "stabilization"):
            self.assertFalse(rospy.has_param(f"/{NAME}/{key}"), key)
        interrupt(first)
        self.wait_gone()
        for scenario in ("pinned_pendulum", "mobile", "chain"):
            node, client = self.start(scenario)
            self.expect_scene_settings(client, scenario)
            interrupt(node)
            self.wait_gone()


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "parameter_ownership", ParameterOwnershipTest)
