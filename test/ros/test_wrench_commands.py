#!/usr/bin/python3
"""~wrench_command and ~anchor_wrench on a pinned chain hanging at rest (hanging_chain.yaml:
n = 4 particles of m = 0.2 kg, links of l = 0.25 m, damping 0.8 N s/m), the node at
real_time_factor 10."""
import math
import threading
import time
import unittest

import rospy
import rostest
from constrained_particles.msg import SimState
from constrained_particles.srv import Reset
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from std_srvs.srv import Empty
from topic_recorder import Recorder
from wall_clock import WallClockWaits

NODE = "/simulator"
N, MASS, LINK, G = 4, 0.2, 0.25, 9.81
TIMEOUT = 0.5  # ~wrench_timeout [s]
PUSH = 0.7     # [N] along +x on the last particle


def command(frame, fx=0.0, fy=0.0, fz=0.0, tx=0.0):
    msg = WrenchStamped()
    msg.header.frame_id = frame
    msg.header.stamp = rospy.Time.now()
    msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = fx, fy, fz
    msg.wrench.torque.x = tx
    return msg


class WrenchCommandsTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("wrench_commands_test")
        for name in ("reset", "pause", "unpause"):
            rospy.wait_for_service(f"{NODE}/{name}", timeout=60.0)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        cls.pause = rospy.ServiceProxy(f"{NODE}/pause", Empty)
        cls.unpause = rospy.ServiceProxy(f"{NODE}/unpause", Empty)
        cls.states = Recorder(f"{NODE}/state", SimState, keep=400)
        cls.wrenches = Recorder(f"{NODE}/anchor_wrench/particle_0", WrenchStamped, keep=400)
        cls.diagnostics = Recorder("/diagnostics", DiagnosticArray, keep=20)
        cls.commands = rospy.Publisher(f"{NODE}/wrench_command", WrenchStamped, queue_size=10)

    def setUp(self):
        self.assertTrue(self.reset("").success)
        self.unpause()
        start = time.monotonic()
        self.wait_until(lambda: self.states.since(start) and self.wrenches.since(start),
                        "~state and ~anchor_wrench/particle_0 after the reset")
        self.wait_until(lambda: self.commands.get_num_connections() > 0, "the node subscribing")

    def diagnostic(self, key, since):
        for array in reversed(self.diagnostics.since(since)):
            for status in array.status:
                for kv in status.values:
                    if kv.key == key:
                        return kv.value
        return None

    def stream(self, frame, fx, seconds, rate=50.0):
        """Publishes a command for `frame` at `rate` for `seconds` (wall); returns when the last
        one went out (time.monotonic())."""
        end = time.monotonic() + seconds
        last = time.monotonic()
        while time.monotonic() < end:
            self.commands.publish(command(frame, fx))
            last = time.monotonic()
            time.sleep(1.0 / rate)
        return last

    def test_a_chain_at_rest_reads_its_weight_at_the_pin(self):
        start = time.monotonic()
        wrench = self.wait_until(lambda: self.wrenches.since(start + 0.5)[-1:], "a wrench")[0]
        weight = N * MASS * G
        f = wrench.wrench.force
        self.assertEqual(wrench.header.frame_id, "world")
        self.assertLessEqual(abs(f.z + weight), 1e-9 * weight, f)
        self.assertLessEqual(math.hypot(f.x, f.y), 1e-9 * weight, f)
        t = wrench.wrench.torque
        self.assertEqual((t.x, t.y, t.z), (0.0, 0.0, 0.0))
        # stamped like ~state: every wrench stamp is a stamp ~state carried
        stamps = {s.header.stamp for s in self.states.since(start)}
        later = [w.header.stamp for w in self.wrenches.since(start + 0.5)]
        self.assertTrue(later)
        self.assertLessEqual(len([s for s in later if s not in stamps]), 1)  # the newest may lead
        # only the held particle has a topic
        topics = [t for t, _ in rospy.get_published_topics() if t.startswith(f"{NODE}/anchor_wrench/")]
        self.assertEqual(topics, [f"{NODE}/anchor_wrench/particle_0"])

    def test_a_steady_push_settles_to_the_statics(self):
        # the chain settles within ~10 s of sim time (damping rate 2/s); streamed until 14 s of
        # sim time have passed since the push began, however slowly a busy machine steps
        stop = threading.Event()

        def push():
            while not stop.is_set():
                self.commands.publish(command("particle_3", PUSH))
                time.sleep(0.02)

        thread = threading.Thread(target=push)
        began = time.monotonic()
        thread.start()
        try:
            t0 = self.wait_until(lambda: next((s.sim_time for s in self.states.since(began)
                                               if s.commanded_particles == 1), None), "the push")
            self.wait_until(lambda: (self.states.latest().sim_time >= t0 + 14.0), "14 s of sim", 120.0)
            start = time.monotonic()
            state = self.wait_until(lambda: self.states.since(start)[-1:], "a state")[0]
            wrench = self.wait_until(lambda: self.wrenches.since(start)[-1:], "a wrench")[0]
        finally:
            stop.set()
            thread.join()
        self.assertEqual(state.commanded_particles, 1)
        # link j (from particle j - 1 to j) carries the push and the weight of particles j..N-1:
        # tan(theta_j) = F / ((N - j) m g) from the vertical, towards +x
        expected = [(0.0, 0.0, 0.0)]
        for j in range(1, N):
            theta = math.atan2(PUSH, (N - j) * MASS * G)
            x, y, z = expected[-1]
            expected.append((x + LINK * math.sin(theta), y, z - LINK * math.cos(theta)))
        for j, (p, e) in enumerate(zip(state.positions, expected)):
            self.assertLessEqual(math.dist((p.x, p.y, p.z), e), 1e-6, f"particle {j}: {p} vs {e}")
        f = wrench.wrench.force
        weight = N * MASS * G
        # the holder is pulled towards the pushed side and down: (F, 0, -n m g)
        self.assertLessEqual(math.dist((f.x, f.y, f.z), (PUSH, 0.0, -weight)), 1e-6 * weight, f)

    def test_a_command_ends_its_timeout_after_the_last_one(self):
        last = self.stream("particle_3", PUSH, 1.0)
        self.assertTrue(any(s.commanded_particles == 1 for s in self.states.since(last - 0.5)))
        # it pushed: the last particle swung out towards +x (its statics put it 0.16 m out)
        self.assertTrue(any(s.positions[3].x > 0.05 for s in self.states.since(last - 0.5)))
        ended = self.wait_until(
            lambda: next((t for t, s in self.states.items if t > last and s.commanded_particles == 0),
                         None), "the command ending", 10.0)
        # not before its timeout (two publish periods of slack for ~state's rate), and not long after
        self.assertGreaterEqual(ended - last, TIMEOUT - 2.0 / 30.0)
        self.assertLessEqual(ended - last, TIMEOUT + 1.0)
        # and the push ended with it: the chain swings back through x = 0 towards its rest
        self.assertTrue(self.wait_until(
            lambda: any(s.positions[3].x < 0.05 for s in self.states.since(ended)), "swinging back", 10.0))

    def test_bad_commands_are_dropped_counted_and_change_nothing(self):
        # the chain hangs at rest and runs: a bad command taken would push it off x = 0
        start = time.monotonic()
        self.wait_until(lambda: self.states.since(start + 0.2), "a state")
        dropped_before = int(self.wait_until(
            lambda: self.diagnostic("wrench commands dropped", start), "/diagnostics' count"))
        bad = [command("particle_4"), command("particle_"), command("world"), command(""),
               command("particle_-1"), command("particle_03"), command("particle_3", fx=float("nan")),
               command("particle_3", fz=float("inf")), command("particle_3", tx=float("nan")),
               command("particle_3", fy=2e9)]
        first = time.monotonic()
        for msg in bad:
            self.commands.publish(msg)
            time.sleep(0.05)
        sent = time.monotonic()
        self.wait_until(lambda: (self.diagnostic("wrench commands dropped", sent + 1.1) or "0") ==
                        str(dropped_before + len(bad)), f"{len(bad)} more dropped", 20.0)
        reason = self.diagnostic("last wrench command dropped", sent)
        self.assertIn("wrench.force.y", reason)
        # while they keep coming, /diagnostics warns (a controller sending to a wrong frame)
        self.assertTrue(any(s.level == DiagnosticStatus.WARN and "messages dropped" in s.message
                            for a in self.diagnostics.since(first) for s in a.status))
        during = self.states.since(first)
        self.assertGreater(len(during), 10)
        self.assertEqual([s.steps for s in during if s.commanded_particles != 0], [])
        self.assertLessEqual(max(abs(p.x) + abs(p.y) for s in during for p in s.positions), 1e-9)
        self.assertEqual(self.states.latest().status, SimState.STATUS_RUNNING)


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "wrench_commands", WrenchCommandsTest)
