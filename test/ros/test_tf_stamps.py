#!/usr/bin/python3
"""With ~publish_clock, no tf stamp is sent twice or goes back: two tf2 listeners (tf_probe), one
following /clock and one on wall time, count tf2's own TF_REPEATED_DATA and TF_OLD_DATA
warnings while the node runs, pauses, steps, teleports, runs at dt = 0.1 s, falls behind and
resets; each time sim time moves, both must hold the newest frames (none frozen). Every wait is
a wall-clock deadline, never a sim-time one (sim time stands still while paused)."""
import threading
import time
import unittest

import rospy
import rostest
from wall_clock import WallClockWaits
from constrained_particles.msg import SimState
from constrained_particles.srv import Reset, SetChain, SetState, Step
from diagnostic_msgs.msg import DiagnosticStatus
from dynamic_reconfigure.client import Client
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Empty

NODE = "/simulator"
PROBES = ("probe_sim", "probe_wall")


class TfStampsTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("tf_stamps_test")
        for name in ("reset", "pause", "unpause", "step", "set_state", "set_chain"):
            rospy.wait_for_service(f"{NODE}/{name}", timeout=60.0)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        cls.pause = rospy.ServiceProxy(f"{NODE}/pause", Empty)
        cls.unpause = rospy.ServiceProxy(f"{NODE}/unpause", Empty)
        cls.step = rospy.ServiceProxy(f"{NODE}/step", Step)
        cls.set_state = rospy.ServiceProxy(f"{NODE}/set_state", SetState)
        cls.set_chain = rospy.ServiceProxy(f"{NODE}/set_chain", SetChain)
        cls.reconfigure = Client(NODE, timeout=60.0)
        cls.lock = threading.Lock()
        cls.reports = {}
        cls.state = None
        cls.clocks = []
        for probe in PROBES:
            rospy.Subscriber(f"/{probe}/report", DiagnosticStatus,
                             lambda m, p=probe: cls.store_report(p, m))
        rospy.Subscriber(f"{NODE}/state", SimState, cls.store_state, queue_size=1)
        rospy.Subscriber("/clock", Clock, lambda m: cls.clocks.append(m.clock.to_sec()))

    @classmethod
    def store_report(cls, probe, message):
        with cls.lock:
            cls.reports[probe] = {kv.key: kv.value for kv in message.values}

    @classmethod
    def store_state(cls, message):
        with cls.lock:
            cls.state = message


    def latest_state(self):
        with self.lock:
            return self.state

    def report(self, probe):
        with self.lock:
            return dict(self.reports.get(probe, {}))

    def assert_clean(self, phase):
        for probe in PROBES:
            r = self.report(probe)
            self.assertEqual(r.get("repeated"), "0", f"{probe} after {phase}: {r}")
            self.assertEqual(r.get("old_data"), "0", f"{probe} after {phase}: {r}")

    def assert_not_frozen(self, phase):
        """Both listeners reach the newest ~state: same stamp, same particle_1 position."""
        self.wait_until(lambda: self.latest_state() is not None, "~state")
        target = self.latest_state()
        stamp = target.header.stamp.to_sec()
        for probe in PROBES:
            self.wait_until(lambda: float(self.report(probe).get("stamp", "-1")) >= stamp - 1e-9,
                            f"{probe} holding frames stamped {stamp} ({phase})")
        if target.status != SimState.STATUS_RUNNING:
            # standing still: the frames they hold are exactly the last state's
            for probe in PROBES:
                r = self.report(probe)
                self.assertAlmostEqual(float(r["stamp"]), stamp, places=6, msg=f"{probe} {phase}")
                self.assertAlmostEqual(float(r["x"]), target.positions[1].x, places=6,
                                       msg=f"{probe} {phase}")
        self.assert_clean(phase)

    def sim_advances(self, seconds):
        start = self.latest_state().sim_time
        self.wait_until(lambda: self.latest_state().sim_time >= start + seconds,
                        f"sim time advancing by {seconds} s")

    def test_no_repeated_or_old_stamps_and_no_frozen_frames(self):
        for probe in PROBES:
            self.wait_until(lambda: "stamp" in self.report(probe), f"a transform on {probe}")
        self.wait_until(lambda: self.latest_state() is not None, "~state")
        # 3 s at 30 Hz: with the phases below, well over the 100 clocks checked at the end
        self.sim_advances(3.0)
        self.assert_not_frozen("running")

        self.pause()
        # paused: a second and a half of wall time in which nothing may be re-sent
        self.wait_until(lambda: self.latest_state().status == SimState.STATUS_PAUSED, "pause")
        time.sleep(1.5)
        self.assert_not_frozen("paused")

        stepped = self.step(300)
        self.assertTrue(stepped.success)
        # the ~step's last state, not one published during it: `before` below must be the newest
        self.wait_until(lambda: abs(self.latest_state().sim_time - stepped.sim_time) < 1e-9,
                        "~state at the end of the ~step")
        self.assert_not_frozen("~step")

        # a teleport at the same sim time: sent once, with a new stamp
        before = self.latest_state().header.stamp.to_sec()
        positions = self.latest_state().positions
        self.assertTrue(self.set_state(positions=positions, velocities=[]).success)
        self.wait_until(lambda: self.latest_state().header.stamp.to_sec() > before,
                        "~state after the teleport")
        self.assert_not_frozen("teleport")

        # dt longer than the publish period: stamps come every dt, never twice
        self.reconfigure.update_configuration({"dt": 0.1})
        self.unpause()
        self.sim_advances(2.0)
        self.assert_not_frozen("dt = 0.1 s")

        # behind: a long chain asked for 100x real time
        self.reconfigure.update_configuration({"dt": 0.001, "real_time_factor": 100.0})
        self.assertTrue(self.set_chain(num_particles=2000, link_length=0.5, particle_mass=1.0).success)
        self.wait_until(lambda: self.latest_state().behind, "behind on ~state")
        self.sim_advances(0.5)
        self.assert_not_frozen("behind")

        # a reset: time goes back to 0 in the scene, the clock runs on
        self.reconfigure.update_configuration({"real_time_factor": 1.0})
        last_clock = self.clocks[-1]
        self.assertTrue(self.reset("chain").success)
        self.wait_until(lambda: self.latest_state().scenario == "chain" and
                        len(self.latest_state().positions) == 5 and
                        self.latest_state().sim_time > 0.5, "the reset chain running")
        self.assertGreater(self.latest_state().header.stamp.to_sec(), last_clock)
        self.pause()
        self.wait_until(lambda: self.latest_state().status == SimState.STATUS_PAUSED, "pause")
        self.assert_not_frozen("reset")

        # from the third message on: roscpp's latched publisher hands a new subscriber the last
        # message after adding its link, outside the lock its publishing thread takes
        # (Publication::addSubscriberLink), so the first message and one published meanwhile may
        # arrive twice or swapped: the transport's, at connection, not the node's stamps
        clocks = list(self.clocks)[2:]
        self.assertGreater(len(clocks), 100)
        self.assertTrue(all(b > a for a, b in zip(clocks, clocks[1:])),
                        "/clock repeated or went back")
        for probe in PROBES:
            self.assertGreater(int(self.report(probe)["lookups"]), 100)


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "tf_stamps", TfStampsTest)
