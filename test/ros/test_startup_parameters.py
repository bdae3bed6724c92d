#!/usr/bin/python3
"""A bad parameter at start-up stops simulator_node with a message naming the parameter."""
import os
import subprocess
import tempfile
import time
import unittest

import rospy
import rostest
from constrained_particles.msg import SimState
from constrained_particles.srv import ListScenes

# wall-clock bounds on waits for something that must happen: a node start on a loaded machine
# can take 10 s and more
STARTUP = 60.0


def run_node(name, *assignments, timeout=STARTUP):
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
            (("fixed_frame", "particle_1"),),  # a particle frame: its own parent
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
            name = f"good_simulator_{index}"
            with tempfile.TemporaryDirectory() as folder:
                path = os.path.join(folder, "output.log")
                with open(path, "w") as log:
                    node = subprocess.Popen(
                        ["rosrun", "constrained_particles", "simulator_node", f"__name:={name}",
                         f"_scenario:={scene}"], stdout=log, stderr=subprocess.STDOUT)

                def output():
                    with open(path, errors="replace") as log:
                        return log.read()
                states = []
                subscriber = rospy.Subscriber(f"/{name}/state", SimState, states.append)
                try:
                    # running = serving (a service answers only once the node is constructed:
                    # parameters read, scene built) and publishing a while (10 ~state messages)
                    served = self.answers(f"/{name}/list_scenes", node, STARTUP)
                    deadline = time.monotonic() + STARTUP
                    while served and node.poll() is None and len(states) < 10 and \
                            time.monotonic() < deadline:
                        time.sleep(0.05)
                    self.assertIsNone(node.poll(), f"node with good parameters exited: {output()}")
                    self.assertTrue(served, f"node with good parameters did not serve within "
                                            f"{STARTUP} s: {output()}")
                    self.assertGreaterEqual(len(states), 10, f"node with good parameters did not "
                                            f"publish 10 ~state within {STARTUP} s: {output()}")
                finally:
                    subscriber.unregister()
                    node.terminate()
                    try:
                        node.wait(timeout=30)
                    except subprocess.TimeoutExpired:
                        node.kill()
                        node.wait()

    @staticmethod
    def answers(service, node, timeout):
        """Polls `service` until a call to it succeeds (True), the node exits or the wall-clock
        deadline passes (False)."""
        deadline = time.monotonic() + timeout
        proxy = rospy.ServiceProxy(service, ListScenes)
        while node.poll() is None and time.monotonic() < deadline:
            try:
                rospy.wait_for_service(service, timeout=max(0.1, min(1.0, deadline - time.monotonic())))
                proxy()
                return True
            except (rospy.ROSException, rospy.ServiceException):
                time.sleep(0.1)
        return False


if __name__ == "__main__":
    rospy.init_node("startup_parameters_test", anonymous=True)
    rostest.rosrun("constrained_particles", "startup_parameters", StartupParametersTest)
