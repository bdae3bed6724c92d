#!/usr/bin/python3
"""launch/two_simulators.launch: each simulator's frames carry its namespace and its topics are
its own; a node asking for /clock while another publishes it is refused at start-up, naming
~publish_clock. Waits are wall-clock deadlines with polling."""
import os
import subprocess
import threading
import time
import unittest

import rospy
import rostest
from wall_clock import WallClockWaits
from constrained_particles.msg import SimState
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage


class TwoSimulatorsTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("two_simulators_test")
        cls.lock = threading.Lock()
        cls.frames = {}  # child frame -> parent
        cls.states = {}
        rospy.Subscriber("/tf", TFMessage, cls.store_tf, queue_size=100)
        for side in ("left", "right"):
            rospy.Subscriber(f"/{side}/simulator/state", SimState,
                             lambda m, s=side: cls.store_state(s, m), queue_size=1)

    @classmethod
    def store_tf(cls, message):
        with cls.lock:
            for t in message.transforms:
                cls.frames[t.child_frame_id] = t.header.frame_id

    @classmethod
    def store_state(cls, side, message):
        with cls.lock:
            cls.states[side] = message


    def test_frames_and_topics_are_separate(self):
        self.wait_until(lambda: len(self.states) == 2, "~state from both simulators")
        with self.lock:
            left, right = self.states["left"], self.states["right"]
        self.assertEqual(left.scenario, "chain")
        self.assertEqual(right.scenario, "mobile")
        counts = {"left": len(left.positions), "right": len(right.positions)}
        for side, n in counts.items():
            for i in range(n):
                frame = f"{side}/particle_{i}"
                self.wait_until(lambda: frame in self.frames, f"frame {frame}")
        with self.lock:
            frames = dict(self.frames)
        self.assertEqual(len(frames), sum(counts.values()), sorted(frames))
        self.assertTrue(all(parent == "world" for parent in frames.values()))
        self.assertFalse([f for f in frames if f.startswith("particle_")])

    def test_second_clock_publisher_is_refused(self):
        # a clock publisher of our own, as a first simulator with ~publish_clock would be
        clock = rospy.Publisher("/clock", Clock, queue_size=1)
        self.wait_until(lambda: "/clock" in dict(rospy.get_published_topics()), "/clock advertised")
        try:
            done = subprocess.run(
                ["rosrun", "constrained_particles", "simulator_node", "__name:=simulator",
                 "__ns:=third", "_scenario:=bead", "_publish_clock:=true"],
                capture_output=True, text=True, timeout=120.0, env=os.environ)
        finally:
            clock.unregister()
        output = done.stdout + done.stderr
        self.assertEqual(done.returncode, 1, output)
        self.assertIn("~publish_clock", output)
        self.assertIn(rospy.get_name(), output)


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "two_simulators", TwoSimulatorsTest)
