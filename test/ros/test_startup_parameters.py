#!/usr/bin/python3
"""A bad parameter at start-up stops simulator_node with a message naming the parameter."""
import subprocess
import unittest

import rospy
import rostest


def run_node(name, *assignments, timeout=30.0):
    """Starts simulator_node with private parameter assignments; returns (exit code, output)."""
    command = ["rosrun", "constrained_particles", "simulator_node", f"__name:={name}"]
    command += [f"_{key}:={value}" for key, value in assignments]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired as expired:
        return None, str(expired.stdout) + str(expired.stderr)
    return done.returncode, done.stdout + done.stderr


class StartupParametersTest(unittest.TestCase):
    def test_bad_parameters_stop_the_node_naming_them(self):
        cases = [
            (("chain/link_length", "-1.0"),),
            (("chain/num_particles", "0"),),
            (("dt", "0.0"),),
            (("dt", "nan"),),
            (("integrator", "leapfrog"),),
            (("stabilization", "magic"),),
            (("scenario", "pendulum"),),
            (("scenario", "/no/such/scene.yaml"),),
            (("max_particles", "3"), ("scenario", "chain")),
            (("surface/type", "cone"),),
            (("publish_rate", "-5"),),
            (("gravity", "[0, 0]"),),
            (("fixed_frame", "/world"),),
            (("surface/expression", "sin(x"), ("surface/type", "expression")),
        ]
        problems = []
        for index, assignments in enumerate(cases):
            code, output = run_node(f"bad_simulator_{index}", *assignments)
            # the parameter the message must name: the last one for the scene-size case
            parameter = assignments[-1][0] if assignments[0][0] == "max_particles" else assignments[0][0]
            if code is None:
                problems.append(f"~{parameter}: node kept running")
            elif code == 0:
                problems.append(f"~{parameter}: node exited 0")
            elif f"~{parameter}" not in output:
                problems.append(f"~{parameter}: not named in the output {output!r}")
        self.assertEqual(problems, [])

    def test_good_parameters_run(self):
        for index, scene in enumerate(("bead", "mobile")):
            code, output = run_node(f"good_simulator_{index}", ("scenario", scene), timeout=5.0)
            self.assertIsNone(code, f"node with good parameters exited: {output}")


if __name__ == "__main__":
    rospy.init_node("startup_parameters_test", anonymous=True)
    rostest.rosrun("constrained_particles", "startup_parameters", StartupParametersTest)
