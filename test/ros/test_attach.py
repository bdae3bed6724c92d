#!/usr/bin/python3
"""~attach, ~detach: grab a free particle with frame 'gripper', move it, let it fall."""
import math
import time
import unittest

import rospy
import rostest
import tf2_ros
from constrained_particles.msg import SimState
from constrained_particles.srv import Attach, Detach, Reset
from geometry_msgs.msg import TransformStamped, Vector3
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Empty
from topic_recorder import Recorder
from wall_clock import WallClockWaits

NODE = "/simulator"
START_NS = 1_733_000_000_000_000_000
TICK_NS = 10_000_000
LAG_NS = 300_000_000  # ~anchor_lag: fixed here (generous: broadcasts may arrive late on a busy machine)
SPEED = 0.5  # the gripper's speed along x [m/s]
G = 9.81


def stamp_of(ns):
    return rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000)


def gripper(ns, moving_from):
    """(0, 0, 1) until moving_from, then along +x at SPEED."""
    return (SPEED * max(ns - moving_from, 0) * 1e-9, 0.0, 1.0)


class AttachTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("attach_test")
        cls.states = Recorder(f"{NODE}/state", SimState, keep=5000)
        cls.clock = rospy.Publisher("/clock", Clock, queue_size=100)
        cls.tf = tf2_ros.TransformBroadcaster()
        rospy.wait_for_service(f"{NODE}/attach", timeout=60.0)
        cls.attach = rospy.ServiceProxy(f"{NODE}/attach", Attach)
        cls.detach = rospy.ServiceProxy(f"{NODE}/detach", Detach)
        cls.pause = rospy.ServiceProxy(f"{NODE}/pause", Empty)
        cls.unpause = rospy.ServiceProxy(f"{NODE}/unpause", Empty)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)

    def run_clock(self, now, ticks, where=None, lag=0):
        """Advances /clock `ticks` ticks from `now` (broadcasting the gripper at where(ns) at each
        tick when given); returns the clock reached, once the node's state stands for it less
        `lag` [ns], the latency the node keeps behind the clock while it holds a particle (from
        an attach on it stands still for the lag, then follows the lag behind)."""
        for _ in range(ticks):
            now += TICK_NS
            if where:
                t = TransformStamped()
                t.header.stamp = stamp_of(now)
                t.header.frame_id = "world"
                t.child_frame_id = "gripper"
                (t.transform.translation.x, t.transform.translation.y,
                 t.transform.translation.z) = where(now)
                t.transform.rotation.w = 1.0
                self.tf.sendTransform(t)
            msg = Clock()
            msg.clock = stamp_of(now)
            self.clock.publish(msg)
            time.sleep(0.01)
        self.wait_until(lambda: (lambda s: s and s.header.stamp.to_nsec() >= now - lag)(
            self.states.latest()), "the state at the last clock less the latency", poll=0.05)
        return now

    def test_grab_move_let_go(self):
        self.wait_until(lambda: self.clock.get_num_connections() > 0, "the node subscribing")
        # the particle falls until grabbed: hold it still first by grabbing it at once
        msg = Clock()
        msg.clock = stamp_of(START_NS)
        self.wait_until(lambda: (self.clock.publish(msg), self.states.latest())[1], "a state",
                        poll=0.05)
        # bad requests: refused naming the field, nothing changed
        before = self.states.latest()
        for request, field in (((5, "gripper", Vector3(), False), "particle"),
                               ((0, "", Vector3(), False), "frame"),
                               ((0, "gripper", Vector3(2e6, 0, 0), False), "offset"),
                               ((0, "nowhere", Vector3(), True), "frame")):
            reply = self.attach(*request)
            self.assertFalse(reply.success, request)
            self.assertTrue(reply.message.startswith(field), reply.message)
        reply = self.detach(0)
        self.assertFalse(reply.success)
        self.assertIn("not attached", reply.message)
        self.assertEqual(list(self.states.latest().held_particles), [])
        self.assertEqual(self.states.latest().steps, before.steps)
        # grab: the gripper at the particle's start, still; attached at offset 0
        moving_from = START_NS + 10 ** 12  # not yet
        now = self.run_clock(START_NS, 5, lambda ns: gripper(ns, moving_from))
        reply = self.attach(0, "gripper", Vector3(), False)
        self.assertTrue(reply.success, reply.message)
        # it had fallen for the 5 ticks since the start: the attach moved it back up to the
        # gripper's point (offset 0) at the state it took hold at, and says how far
        self.assertAlmostEqual(reply.moved, 0.5 * G * (5 * TICK_NS * 1e-9) ** 2, places=9)
        self.assertEqual(reply.stamp, stamp_of(now))  # the hold began at the state of the clock
        self.assertFalse(self.attach(0, "gripper", Vector3(), False).success)  # already held
        # held, the node runs ~anchor_lag behind the clock: it stands still for the lag first
        now = self.run_clock(now, 40, lambda ns: gripper(ns, moving_from), LAG_NS)
        held = self.states.latest()
        self.assertEqual(list(held.held_particles), [0])
        self.assertEqual(list(held.holders), ["gripper"])
        self.assertAlmostEqual(held.anchor_lag, LAG_NS * 1e-9)
        # it survives a pause (unpaused, it stands still for the lag again)
        self.pause()
        self.unpause()
        now = self.run_clock(now, 40, lambda ns: gripper(ns, moving_from), LAG_NS)
        self.assertEqual(list(self.states.latest().held_particles), [0])
        # the gripper moves along +x: the particle follows it, at the gripper's pose at each stamp
        moving_from = now + TICK_NS
        followed_from = now
        now = self.run_clock(now, 100, lambda ns: gripper(ns, moving_from), LAG_NS)
        worst = 0.0
        checked = 0
        for state in self.states.since(0.0):
            t_ns = state.header.stamp.to_nsec()
            if t_ns < moving_from + 3 * TICK_NS or t_ns <= followed_from - LAG_NS:
                continue
            p = state.positions[0]
            worst = max(worst, math.dist((p.x, p.y, p.z), gripper(t_ns, moving_from)))
            checked += 1
        self.assertGreater(checked, 10)
        self.assertLess(worst, 1e-6)
        # let go while the clock stands: it goes on from the velocity it had
        let_go = self.states.latest()
        self.assertLess(abs(let_go.velocities[0].x - SPEED), 1e-6)
        reply = self.detach(0)
        self.assertTrue(reply.success, reply.message)
        # under ~follow_clock nothing goes out until the clock moves: one tick
        now = self.run_clock(now, 1)
        released = self.states.latest()
        self.assertEqual(list(released.held_particles), [])
        p0, v0, t0 = released.positions[0], released.velocities[0], released.sim_time
        self.assertLess(abs(v0.x - SPEED), 1e-6)
        now = self.run_clock(now, 50, lambda ns: gripper(ns, moving_from))  # it goes on, unheard
        fallen = self.states.latest()
        dt = fallen.sim_time - t0
        self.assertGreater(dt, 0.45)
        self.assertEqual(fallen.status, SimState.STATUS_RUNNING, fallen.status_message)
        p = fallen.positions[0]
        expected = (p0.x + v0.x * dt, p0.y + v0.y * dt, p0.z + v0.z * dt - 0.5 * G * dt * dt)
        self.assertLess(math.dist((p.x, p.y, p.z), expected), 1e-6)
        # grabbed again, a reset ends it
        self.assertTrue(self.attach(0, "gripper", Vector3(), True).success)
        now = self.run_clock(now, 40, lag=LAG_NS)
        self.assertEqual(list(self.states.latest().held_particles), [0])
        self.assertTrue(self.reset("").success)
        now = self.run_clock(now, 1)
        self.assertEqual(list(self.states.latest().held_particles), [])


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "attach", AttachTest)
