#!/usr/bin/python3
"""launch/simulator.launch as a user starts it (launch_arguments.test): params:= wins over the
launch file's scenario and status_period (the node runs bead with a status line every 2 s), a
config:= file wins over them too, and params:="{status_period: -1}" stops the node with a
message naming ~status_period. Waits are wall-clock deadlines with polling."""
import os
import re
import signal
import statistics
import subprocess
import tempfile
import time
import unittest

import rospy
import rostest
from constrained_particles.msg import SimState
from topic_recorder import Recorder
from wall_clock import WallClockWaits

NODE = "/simulator"
# rosconsole's INFO line: "[ INFO] [<wall seconds>]: t = ..." (the node's status line)
STATUS_LINE = re.compile(r"\[ INFO\] \[(\d+\.\d+)\]: t = ")


class Launch:
    """roslaunch constrained_particles simulator.launch <args>, its output in a file."""

    def __init__(self, *args):
        self.log = tempfile.NamedTemporaryFile("w+", prefix="launch_", suffix=".log")
        self.process = subprocess.Popen(
            ["roslaunch", "constrained_particles", "simulator.launch", "rviz:=false", *args],
            stdout=self.log, stderr=subprocess.STDOUT, start_new_session=True,
            # rosconsole flushes stdout per line only when asked: the status lines are read live
            env=dict(os.environ, ROSCONSOLE_STDOUT_LINE_BUFFERED="1"))

    def output(self):
        with open(self.log.name, errors="replace") as f:
            return f.read()

    def stop(self):
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGINT)  # roslaunch and its nodes: ours
            try:
                self.process.wait(timeout=30.0)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()
        self.log.close()


class LaunchArgumentsTest(WallClockWaits, unittest.TestCase):
    def run_until_state(self, launch):
        """Waits for the launched node's ~state; returns it."""
        states = Recorder(f"{NODE}/state", SimState, keep=10)
        try:
            return self.wait_until(
                lambda: states.latest() or (launch.process.poll() is not None and
                                            self.fail(f"roslaunch exited: {launch.output()}")),
                "the launched node's ~state", timeout=120.0)
        finally:
            states.subscriber.unregister()

    def test_params_win_over_the_launch_file(self):
        launch = Launch('params:={scenario: bead, status_period: 2.0}')
        try:
            state = self.run_until_state(launch)
            self.assertEqual(state.scenario, "bead")
            self.assertEqual(rospy.get_param(f"{NODE}/status_period"), 2.0)
            # the status lines come every 2 s of wall time (their own stamps, however late read)
            self.wait_until(lambda: len(STATUS_LINE.findall(launch.output())) >= 5,
                            "five status lines", timeout=120.0)
            stamps = [float(s) for s in STATUS_LINE.findall(launch.output())]
            gaps = [b - a for a, b in zip(stamps, stamps[1:])]
            self.assertAlmostEqual(statistics.median(gaps), 2.0, delta=0.3, msg=gaps)
        finally:
            launch.stop()

    def test_a_config_file_wins_over_the_launch_file(self):
        with tempfile.NamedTemporaryFile("w", suffix=".yaml") as config:
            config.write("scenario: mobile\n")
            config.flush()
            launch = Launch(f"config:={config.name}")
            try:
                self.assertEqual(self.run_until_state(launch).scenario, "mobile")
            finally:
                launch.stop()

    def test_a_bad_value_through_params_stops_the_node_naming_it(self):
        for params, parameter in (("{status_period: -1}", "~status_period"),
                                  ("{scenario: 7}", "~scenario")):
            launch = Launch(f"params:={params}")
            try:
                # the node is required: roslaunch ends with it
                self.wait_until(lambda: launch.process.poll() is not None,
                                f"roslaunch ending after params:={params}", timeout=120.0)
                output = launch.output()
                self.assertIn(f"bad parameter: {parameter}", output)
                self.assertIsNone(re.search(STATUS_LINE, output), output)
            finally:
                launch.stop()


if __name__ == "__main__":
    rospy.init_node("launch_arguments_test")
    rostest.rosrun("constrained_particles", "launch_arguments", LaunchArgumentsTest)
