#!/usr/bin/python3
"""With ~publish_clock, /clock is the node's clock: sim time plus the sim time of earlier resets
(and 1 ms per reset or teleport), so it never goes back. Paused it stands, stepped it advances by
exactly the steps, running it advances at about the real-time factor; a reset moves it forward;
stamps follow it."""
import time
import unittest

import rospy
import rostest
import tf2_ros
from constrained_particles.msg import SimState
from constrained_particles.srv import Reset, Step
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Empty

NODE = "/simulator"


class SimClockTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("sim_clock_test")
        for name in ("reset", "pause", "unpause", "step"):
            rospy.wait_for_service(f"{NODE}/{name}", timeout=60.0)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        cls.pause = rospy.ServiceProxy(f"{NODE}/pause", Empty)
        cls.unpause = rospy.ServiceProxy(f"{NODE}/unpause", Empty)
        cls.step = rospy.ServiceProxy(f"{NODE}/step", Step)
        cls.states = []
        cls.clocks = []
        rospy.Subscriber(f"{NODE}/state", SimState, lambda m: cls.states.append(m), queue_size=10)
        rospy.Subscriber("/clock", Clock, lambda m: cls.clocks.append(m), queue_size=10)
        cls.tf_buffer = tf2_ros.Buffer()
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)

    def index_at(self, sim_time, since, timeout=30.0):
        """The index in self.states of the first state at `sim_time` [s] from self.states[since]
        on (the scene ran through the same sim times before a reset, with other stamps); waits
        in wall time: with use_sim_time, rospy's clock is the node's sim time."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for k in range(since, len(self.states)):
                if abs(self.states[k].sim_time - sim_time) < 1e-9:
                    return k
            time.sleep(0.01)
        self.fail(f"no ~state at sim time {sim_time} s")

    def state_at(self, sim_time, since):
        return self.states[self.index_at(sim_time, since)]

    def reset_scene(self, name):
        """Resets to `name`; returns the index of its first state (sim time 0) in self.states:
        those after it are the new run's, whatever the old run's came late."""
        before = len(self.states)
        self.assertTrue(self.reset(name).success)
        return self.index_at(0.0, before)

    def wait_clock(self, value):
        """/clock comes on its own connection: wait (wall time) until it shows `value`."""
        deadline = time.monotonic() + 30.0
        while abs(self.clocks[-1].clock.to_sec() - value) > 1e-6 and time.monotonic() < deadline:
            time.sleep(0.01)
        self.assertAlmostEqual(self.clocks[-1].clock.to_sec(), value, places=6)

    def test_clock_is_sim_time(self):
        self.assertTrue(rospy.get_param("/use_sim_time"))
        self.pause()
        mark = self.reset_scene("bead")
        self.assertTrue(self.step(250).success)
        state = self.state_at(0.25, mark)
        # the clock is sim time plus an offset that only resets and teleports change
        offset = state.header.stamp.to_sec() - 0.25
        self.assertGreaterEqual(offset, 0.0)
        self.wait_clock(0.25 + offset)
        self.assertAlmostEqual(rospy.Time.now().to_sec(), 0.25 + offset, places=6)
        # tf is stamped with it too (polled against wall time: sim time stands still here,
        # so can_transform's own timeout would never run out)
        deadline = time.monotonic() + 30.0
        while not self.tf_buffer.can_transform("world", "particle_0", state.header.stamp) and \
                time.monotonic() < deadline:
            time.sleep(0.01)
        self.assertTrue(self.tf_buffer.can_transform("world", "particle_0", state.header.stamp))
        # paused: time stands still for a wall second (the observation window of this check)
        time.sleep(1.0)
        self.assertAlmostEqual(self.states[-1].header.stamp.to_sec(), 0.25 + offset, places=6)
        self.assertAlmostEqual(rospy.Time.now().to_sec(), 0.25 + offset, places=6)
        # /clock is latched: a node joining now learns the time although nothing is re-sent
        late = []
        subscriber = rospy.Subscriber("/clock", Clock, late.append)
        deadline = time.monotonic() + 30.0
        while not late and time.monotonic() < deadline:
            time.sleep(0.01)
        subscriber.unregister()
        self.assertTrue(late, "no /clock for a subscriber joining while paused")
        self.assertAlmostEqual(late[0].clock.to_sec(), 0.25 + offset, places=6)
        # stepping advances it by exactly the steps
        mark = len(self.states)
        self.assertTrue(self.step(100).success)
        self.assertAlmostEqual(self.state_at(0.35, mark).header.stamp.to_sec(), 0.35 + offset,
                               places=6)
        self.wait_clock(0.35 + offset)
        # a reset sends the scene back to t = 0 but moves the clock forward
        mark = self.reset_scene("")
        self.assertTrue(self.step(10).success)
        after = self.state_at(0.01, mark)
        self.assertAlmostEqual(after.header.stamp.to_sec(), 0.35 + offset + 0.001 + 0.01, places=6)
        self.wait_clock(after.header.stamp.to_sec())
        # running: about one sim second per wall second
        self.unpause()
        wall_start, sim_start = time.monotonic(), rospy.Time.now().to_sec()
        time.sleep(2.0)
        rate = (rospy.Time.now().to_sec() - sim_start) / (time.monotonic() - wall_start)
        self.pause()
        self.assertGreater(rate, 0.5)
        self.assertLess(rate, 1.5)
        # from the third message on: roscpp's latched publisher may send the first message and
        # one published as the subscriber connected twice or swapped (the transport's, not the
        # node's stamps; test_tf_stamps.py says why)
        stamps = [s.header.stamp.to_sec() for s in self.states[2:]]
        self.assertGreater(len(stamps), 20)  # 2 s running at 50 Hz: not checked vacuously
        self.assertTrue(all(b > a for a, b in zip(stamps, stamps[1:])), "a ~state stamp repeated")


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "sim_clock", SimClockTest)
