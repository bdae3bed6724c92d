#!/usr/bin/python3
"""launch/two_simulators.launch: each simulator's frames carry its namespace and its topics are
its own; a node asking for /clock while another publishes it is refused at start-up, naming
~publish_clock. Waits are wall-clock deadlines with polling."""
import os
import subprocess
import threading
import time
import unittest

import rosgraph
import rospy
import rostest
from wall_clock import WallClockWaits, interrupt
from constrained_particles.msg import SimState
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage


def clock_publishers():
    """The nodes the master lists as publishing /clock."""
    state = rosgraph.Master("/two_simulators_test").getSystemState()
    return sorted(node for topic, nodes in state[0] if topic == "/clock" for node in nodes)


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
        ours = {f: p for f, p in frames.items() if f.split("/")[0] in counts}
        expected = {f"{side}/particle_{i}" for side, n in counts.items() for i in range(n)}
        self.assertEqual(set(ours), expected)
        self.assertTrue(all(parent == "world" for parent in ours.values()))
        # every simulator here runs in a namespace: no frame without one
        self.assertFalse([f for f in frames if "/" not in f], sorted(frames))

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

    def clock_node(self, name):
        return subprocess.Popen(
            ["rosrun", "constrained_particles", "simulator_node", f"__name:={name}",
             "__ns:=clock_test", "_scenario:=bead", "_publish_clock:=true"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)


    def test_two_clock_nodes_started_together_leave_one(self):
        nodes = [self.clock_node("clock_a"), self.clock_node("clock_b")]
        try:
            # one is refused (exit 1, naming ~publish_clock), whichever way the starts interleave
            self.wait_until(lambda: any(n.poll() is not None for n in nodes), "a refusal", 120.0)
            refused = [n for n in nodes if n.poll() is not None]
            self.assertEqual(len(refused), 1)
            self.assertEqual(refused[0].returncode, 1)
            self.assertIn("~publish_clock", refused[0].stdout.read())
            self.wait_until(lambda: clock_publishers() in (["/clock_test/clock_a"], ["/clock_test/clock_b"]),
                            "one /clock publisher")
            self.assertIsNone([n for n in nodes if n not in refused][0].poll())
        finally:
            for node in nodes:
                interrupt(node)

    def test_a_clock_publisher_sorting_first_soon_after_start_takes_clock(self):
        # two nodes started together may check before the other registers: for a while after
        # advertising, a node keeps checking, and gives way to one whose name sorts first
        node = self.clock_node("clock_b")
        other = None
        try:
            self.wait_until(lambda: clock_publishers() == ["/clock_test/clock_b"],
                            "clock_b publishing /clock", 120.0)
            other = subprocess.Popen(
                ["rostopic", "pub", "-r", "10", "/clock", "rosgraph_msgs/Clock",
                 "{clock: {secs: 1, nsecs: 0}}", "__name:=aaa_clock"],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
            self.wait_until(lambda: node.poll() is not None, "clock_b giving way", 60.0)
            output = node.stdout.read()
            self.assertEqual(node.returncode, 1, output)
            self.assertIn("~publish_clock", output)
            self.assertIn("/aaa_clock", output)
        finally:
            interrupt(node)
            if other is not None:
                interrupt(other)

    def test_a_remapped_clock_is_checked_under_its_own_name(self):
        # /clock remapped into the node's namespace while another node publishes the real /clock:
        # only the remapped name must be free
        clock = rospy.Publisher("/clock", Clock, queue_size=1)
        self.wait_until(lambda: "/clock" in dict(rospy.get_published_topics()), "/clock advertised")
        ticks = []
        subscriber = rospy.Subscriber("/robot1/clock", Clock, ticks.append)
        node = subprocess.Popen(
            ["rosrun", "constrained_particles", "simulator_node", "__name:=simulator",
             "__ns:=robot1", "/clock:=/robot1/clock", "_scenario:=bead", "_publish_clock:=true"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
        try:
            publishers = lambda topic: sorted(
                n for t, nodes in rosgraph.Master("/two_simulators_test").getSystemState()[0]
                if t == topic for n in nodes)
            self.wait_until(lambda: node.poll() is not None or
                            publishers("/robot1/clock") == ["/robot1/simulator"],
                            "the node publishing /robot1/clock", 120.0)
            self.assertIsNone(node.poll(), node.stdout.read() if node.poll() is not None else "")
            # its clock runs on the remapped name (sim time moving), and the real one is not its
            self.wait_until(lambda: len({t.clock.to_sec() for t in ticks}) >= 3,
                            "three distinct ticks on /robot1/clock")
            self.assertNotIn("/robot1/simulator", publishers("/clock"))
            # past the first checks after advertising (one a second): still running
            time.sleep(3.0)
            self.assertIsNone(node.poll(), node.stdout.read() if node.poll() is not None else "")
        finally:
            subscriber.unregister()
            clock.unregister()
            interrupt(node)

    def test_a_dead_clock_publisher_does_not_block_a_start(self):
        # a publisher the master still lists but that no longer answers (as after SIGKILL)
        master = rosgraph.Master("/ghost")
        master.registerPublisher("/clock", "rosgraph_msgs/Clock", "http://localhost:9/")
        node = self.clock_node("after_ghost")
        try:
            self.wait_until(lambda: node.poll() is not None or
                            "/clock_test/after_ghost" in clock_publishers(), "the node publishing /clock",
                            120.0)
            self.assertIsNone(node.poll(), node.stdout.read() if node.poll() is not None else "")
        finally:
            interrupt(node)
            master.unregisterPublisher("/clock", "http://localhost:9/")


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "two_simulators", TwoSimulatorsTest)
