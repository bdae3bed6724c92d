#!/usr/bin/python3
"""/use_sim_time without a clock of the node's own (foreign_clock.test): before any /clock the
node publishes no tf or ~state (their stamps would all be 0) and /diagnostics says why (WARN,
naming ~publish_clock); with a foreign /clock at 20 Hz beside the node's 30 Hz publishing, a tf2
listener (tf_probe) sees no TF_REPEATED_DATA and no stamp reaches /tf or ~state twice. Every wait
is a wall-clock deadline: rospy's own clock is the stopped sim time here."""
import threading
import time
import unittest

import rospy
import rostest
from constrained_particles.msg import SimState
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage
from topic_recorder import Recorder
from wall_clock import WallClockWaits

NODE = "/simulator"
CLOCK_RATE = 20.0  # Hz: slower than the node's publish_rate, as a foreign clock often is


def ours(message):
    """The node's /tf messages (the probe's are none; others' would not be particle frames)."""
    return message.transforms and message.transforms[0].child_frame_id.startswith("particle_")


class ForeignClockTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("foreign_clock_test")
        rospy.wait_for_service(f"{NODE}/list_scenes", timeout=60.0)
        cls.tf = Recorder("/tf", TFMessage, keep=5000)
        cls.states = Recorder(f"{NODE}/state", SimState, keep=5000)
        cls.diagnostics = Recorder("/diagnostics", DiagnosticArray, keep=200)
        cls.probe = Recorder("/probe/report", DiagnosticStatus, keep=10)

    def node_status(self, since):
        """The node's /diagnostics statuses that arrived since `since` (time.monotonic())."""
        return [s for a in self.diagnostics.since(since) for s in a.status
                if s.name.startswith(NODE)]

    def probe_value(self, key):
        report = self.probe.latest()
        return None if report is None else {kv.key: kv.value for kv in report.values}.get(key)

    def test_no_stamp_zero_then_no_repeated_stamp(self):
        # before a /clock: a WARN naming both remedies, and nothing stamped
        start = time.monotonic()
        warning = self.wait_until(
            lambda: [s for s in self.node_status(start) if "no /clock" in s.message],
            "the WARN about the missing /clock in /diagnostics")[0]
        self.assertEqual(warning.level, DiagnosticStatus.WARN, warning.message)
        self.assertIn("~publish_clock", warning.message)
        self.assertIn("rosbag play --clock", warning.message)
        time.sleep(3.0)  # 90 ticks of the node's publish timer
        self.assertEqual([m for m in self.tf.since(0.0) if ours(m)], [])
        self.assertEqual(self.states.since(0.0), [])

        # a foreign /clock at 20 Hz from 100 s on
        clock = rospy.Publisher("/clock", Clock, queue_size=10)
        stop = threading.Event()

        def run_clock():
            t = 100.0
            while not stop.is_set():
                clock.publish(Clock(clock=rospy.Time.from_sec(t)))
                t += 1.0 / CLOCK_RATE
                time.sleep(1.0 / CLOCK_RATE)

        thread = threading.Thread(target=run_clock, daemon=True)
        thread.start()
        try:
            self.wait_until(lambda: [m for m in self.tf.since(0.0) if ours(m)],
                            "the node's tf once the clock runs")
            self.wait_until(lambda: self.probe_value("lookups") not in (None, "0"),
                            "the probe holding the node's frames")
            window = time.monotonic()
            time.sleep(5.0)
            tf = [m for m in self.tf.since(window) if ours(m)]
            states = self.states.since(window)
            self.wait_until(lambda: self.node_status(time.monotonic() - 1.5),
                            "/diagnostics after the clock started")
            cleared = self.node_status(time.monotonic() - 1.5)
        finally:
            stop.set()
            thread.join()
            clock.unregister()
        # the clock's 100 ticks in 5 s: each stamp at most once (a busy machine may drop some)
        self.assertGreater(len(tf), 20)
        tf_stamps = [m.transforms[0].header.stamp.to_sec() for m in tf]
        self.assertEqual(len(set(tf_stamps)), len(tf_stamps), tf_stamps)
        self.assertNotIn(0.0, tf_stamps)
        self.assertGreater(len(states), 20)
        state_stamps = [s.header.stamp.to_sec() for s in states]
        self.assertEqual(len(set(state_stamps)), len(state_stamps), state_stamps)
        self.assertGreaterEqual(min(state_stamps), 100.0)
        self.assertEqual(self.probe_value("repeated"), "0")
        self.assertEqual(self.probe_value("old_data"), "0")
        # the warning is gone once time moves
        self.assertFalse([s for s in cleared if "no /clock" in s.message],
                         [s.message for s in cleared])


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "foreign_clock", ForeignClockTest)
