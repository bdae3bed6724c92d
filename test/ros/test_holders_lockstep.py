#!/usr/bin/python3
"""Issue 47: a rope in a robot's hand, exactly, through the node. In lockstep with /clock
(~follow_clock, dt 1 ms) the test owns time and broadcasts the holders on tf:
- the hold workload (a 10 x 0.1 kg rope on 0.1 m links, the hand circling r = 0.2 m at 0.5 Hz),
  broadcast every 1 ms and only at 30 Hz stamps: the held particle at the hand at every state's
  stamp within 1e-4 m, the 30 Hz force peak within 1.1x the 1 kHz one, the 1 kHz wrench changing
  from step to step by at most 0.04 N rms;
- a rope held at both ends, one hand walking 0.5 m past its length: no fault, finite, the
  wrenches within the holds' limit, the hold that let go said;
- the clock looping back as rosbag play --loop does: nothing stamped in the old epoch after the
  jump (a sim-time tf2 listener sees the new one), the held end back at its holder within the lag;
- a holder jumping 0.45, 1.2 and 2 m and flickering: teleports counted with their distances, the
  rope's kinetic energy after each as without the jumps (within 1 %);
- ~attach of a swinging tip on a 30 Hz frame: held where it was at the reply's stamp within 1e-6
  m; refusals naming the field.
Every wait is on the wall clock."""
import math
import os
import threading
import time
import unittest

import rospy
import rostest
import tf2_ros
from constrained_particles.msg import SimState
from constrained_particles.srv import Attach, Reset
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import TransformStamped, Vector3, WrenchStamped
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage
from topic_recorder import Recorder, diagnostic_value
from wall_clock import WallClockWaits

NODE = "/simulator"
HERE = os.path.dirname(os.path.abspath(__file__))
WORKLOAD = os.path.join(HERE, "hold_workload.yaml")
TWO_HANDS = os.path.join(HERE, "two_hands.yaml")
START_NS = 1_733_000_000_000_000_000  # the first clock, as a bag's near the epoch
TICK_NS = 1_000_000  # /clock advances 1 ms a tick: dt
PACE = 0.0015  # wall seconds a tick at least: the node takes each clock in a batch of its own


def stamp_of(ns):
    return rospy.Time(ns // 1_000_000_000, ns % 1_000_000_000)


def hand(t):
    """The workload's hand at t [s] into the run: a horizontal circle of 0.2 m at 0.5 Hz about
    (0, 0.2, 1.5), setting off from rest over the first second (angle pi t^2 / 2, then
    pi (t - 1/2)): no start-up jerk to dominate a force peak."""
    angle = math.pi * t * t / 2.0 if t < 1.0 else math.pi * (t - 0.5)
    return (0.2 * math.sin(angle), 0.2 * (1.0 - math.cos(angle)), 1.5)


def norm(v):
    return math.sqrt(v.x * v.x + v.y * v.y + v.z * v.z)


def point(p):
    return (p.x, p.y, p.z)


class HoldersLockstepTest(WallClockWaits, unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("holders_lockstep_test")
        cls.states = Recorder(f"{NODE}/state", SimState, keep=30000, queue_size=5000)
        cls.wrench0 = Recorder(f"{NODE}/anchor_wrench/particle_0", WrenchStamped, keep=30000,
                               queue_size=5000)
        cls.wrench10 = Recorder(f"{NODE}/anchor_wrench/particle_10", WrenchStamped, keep=30000,
                                queue_size=5000)
        cls.tf = Recorder("/tf", TFMessage, keep=30000, queue_size=5000)
        cls.diagnostics = Recorder("/diagnostics", DiagnosticArray, keep=100)
        cls.clock = rospy.Publisher("/clock", Clock, queue_size=1000)
        cls.broadcaster = tf2_ros.TransformBroadcaster()
        rospy.wait_for_service(f"{NODE}/reset", timeout=60.0)
        cls.reset = rospy.ServiceProxy(f"{NODE}/reset", Reset)
        cls.attach = rospy.ServiceProxy(f"{NODE}/attach", Attach)
        cls.clock_ns = START_NS

    # the clock is the class's, across the tests (unittest makes an instance per test)
    @property
    def now(self):
        return type(self).clock_ns

    @now.setter
    def now(self, value):
        type(self).clock_ns = value

    # --- the clock and the holders ---

    def send(self, frames):
        """Broadcasts [(frame, stamp [ns], (x, y, z))] in one /tf message."""
        if not frames:
            return
        transforms = []
        for frame, ns, (x, y, z) in frames:
            t = TransformStamped()
            t.header.stamp = stamp_of(ns)
            t.header.frame_id = "world"
            t.child_frame_id = frame
            t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = x, y, z
            t.transform.rotation.w = 1.0
            transforms.append(t)
        self.broadcaster.sendTransform(transforms)

    def advance(self, ticks, frames_at=None):
        """Advances /clock `ticks` ticks, broadcasting frames_at(now) (a list for send()) before
        each; never more than 0.5 s of clock ahead of the node's newest state."""
        for k in range(ticks):
            begun = time.monotonic()
            self.now += TICK_NS
            if frames_at:
                self.send(frames_at(self.now))
            self.clock.publish(Clock(clock=stamp_of(self.now)))
            if k % 50 == 49:
                self.wait_until(lambda: (lambda s: s and s.header.stamp.to_nsec() >=
                                         self.now - 500_000_000)(self.states.latest()),
                                f"the node within 0.5 s of the clock {self.now} (its newest "
                                f"state: {self.newest()})", poll=0.005)
            left = PACE - (time.monotonic() - begun)
            if left > 0:
                time.sleep(left)

    def newest(self):
        """The newest state's stamp, sim time, latency and status, for a failure's message."""
        s = self.states.latest()
        return s and (s.header.stamp.to_nsec(), s.sim_time, s.anchor_lag, s.status_message)

    def settle(self, frames_at=None):
        """Ticks on until the node's state stands for the newest clock less its latency."""
        def caught_up():
            s = self.states.latest()
            return s and s.header.stamp.to_nsec() >= self.now - round(s.anchor_lag * 1e9) - TICK_NS
        deadline = time.monotonic() + 60.0
        while not caught_up():
            self.assertLess(time.monotonic(), deadline, f"the node catching up with the clock "
                            f"{self.now} (its newest state: {self.newest()})")
            time.sleep(0.05)

    def restart(self, scene):
        """~reset to `scene`: its t = 0 stands for the clock now; returns that clock [ns]."""
        reply = self.reset(scene)
        self.assertTrue(reply.success, reply.message)
        return self.now

    def run_hand(self, scene, seconds, every_ns, path):
        """A run of `scene` with frame 'hand' at path(t) broadcast at stamps every `every_ns`
        from the run's start; returns (start [ns], end [ns], wall mark)."""
        mark = time.monotonic()
        start = self.restart(scene)
        sent = [start]  # the last stamp broadcast

        def frames(now):
            out = []
            while sent[0] + every_ns <= now:
                sent[0] += every_ns
                out.append(("hand", sent[0], path((sent[0] - start) * 1e-9)))
            return out
        self.advance(int(seconds * 1e9) // TICK_NS, frames)
        end = self.now
        # the clock on until the node stands for `end`, the hand still broadcast
        self.advance(int(0.3e9) // TICK_NS, frames)
        self.settle()
        return start, end, mark

    def of_run(self, recorder, mark, start, end):
        """{stamp [ns]: message} of a run, stamps in [start, end]."""
        return {m.header.stamp.to_nsec(): m for m in recorder.since(mark)
                if start <= m.header.stamp.to_nsec() <= end}

    # --- the tests (run in name order, one node) ---

    def test_1_workload_at_1khz_and_30hz(self):
        # the first clock, sent until the node shows its state (this process's own /clock
        # subscription counts as a connection too: the node's may come later)
        self.wait_until(lambda: (self.clock.publish(Clock(clock=stamp_of(self.now))),
                                 self.states.latest())[1], "the node's state at the first clock",
                        poll=0.05)
        figures = {}
        for name, every in (("1 kHz", TICK_NS), ("30 Hz", 33_333_333)):
            start, end, mark = self.run_hand(WORKLOAD, 3.0, every, hand)
            states = self.of_run(self.states, mark, start + 50_000_000, end)
            wrenches = self.of_run(self.wrench0, mark, start + 50_000_000, end)
            self.assertGreater(len(states), 1000, name)
            worst = max(math.dist(point(s.positions[0]), hand((t - start) * 1e-9))
                        for t, s in states.items())
            peak = max(norm(w.wrench.force) for w in wrenches.values())
            steps = sorted(wrenches)
            changes = [math.dist(point(wrenches[a].wrench.force), point(wrenches[b].wrench.force))
                       for a, b in zip(steps, steps[1:]) if b - a == TICK_NS]
            rms = math.sqrt(sum(c * c for c in changes) / len(changes))
            lag = max(s.anchor_lag for s in states.values())
            overruns = states[max(states)].holder_overruns[0]
            figures[name] = (worst, peak, rms, len(changes), lag, overruns,
                             states[max(states)].anchor_lag)
            rospy.loginfo("holders_lockstep %s: held within %.3g m of the hand at %d stamps, "
                          "force peak %.6g N, step-to-step change %.4g N rms over %d steps, "
                          "latency up to %.4g s, overruns %d", name, worst, len(states), peak, rms,
                          len(changes), lag, overruns)
            self.assertLess(worst, 1e-4, f"{name}: held particle {worst} m off the hand")
            self.assertGreater(len(changes), 500, name)
            # every stamp a state stands for is behind the newest clock by its latency at least
            self.assertTrue(all(t <= end + 300_000_000 - round(s.anchor_lag * 1e9) + TICK_NS
                                for t, s in states.items()))
        ratio = figures["30 Hz"][1] / figures["1 kHz"][1]
        print(f"holders_lockstep: 30 Hz / 1 kHz force peak {ratio:.5f}; 1 kHz step-to-step "
              f"change {figures['1 kHz'][2]:.4f} N rms; held error 1 kHz "
              f"{figures['1 kHz'][0]:.3g} m, 30 Hz {figures['30 Hz'][0]:.3g} m; latency at the "
              f"end {figures['1 kHz'][6]:.4f} s, {figures['30 Hz'][6]:.4f} s (at most "
              f"{figures['1 kHz'][4]:.4f} s, {figures['30 Hz'][4]:.4f} s: the first guess)")
        self.assertLessEqual(ratio, 1.1)
        self.assertGreaterEqual(ratio, 1.0 / 1.1)
        self.assertLessEqual(figures["1 kHz"][2], 0.04)

    def test_2_two_hands_pull_the_rope_past_its_length(self):
        mark = time.monotonic()
        start = self.restart(TWO_HANDS)
        s = 0.1 / math.sqrt(2.0)
        left, right = (-5 * s, 0.0, 1.0), (5 * s, 0.0, 1.0)
        speed = 0.5  # [m/s]: from 0.71 m apart to 0.5 m past the rope's 1 m

        def frames(now):
            t = (now - start) * 1e-9
            if (now - start) % 10_000_000:
                return []  # 100 Hz
            x = right[0] + speed * max(0.0, t - 0.2)
            return [("left", now, left), ("right", now, (x, right[1], right[2]))]
        walk = 0.2 + (1.0 - 10 * s + 0.5) / speed
        self.advance(int(walk * 1e9) // TICK_NS + 200, frames)
        self.settle()
        states = self.of_run(self.states, mark, start, self.now)
        self.assertGreater(len(states), 500)
        limit = 50.0 * 1.1 * 9.81  # ~anchor_max_force 0: 50 times the scene's weight
        for t, state in states.items():
            self.assertNotEqual(state.status, SimState.STATUS_FAULT, state.status_message)
            self.assertTrue(all(math.isfinite(v) for p in state.positions for v in point(p)))
            self.assertTrue(all(math.isfinite(v) for v in state.multipliers))
        last = states[max(states)]
        self.assertEqual(len(last.released_particles), 1, "one hold let go")
        self.assertIn(last.released_particles[0], (0, 10))
        self.assertAlmostEqual(last.released_max_forces[0], limit, places=6)
        self.assertEqual(len(last.held_particles), 1)
        largest = 0.0
        for recorder in (self.wrench0, self.wrench10):
            for w in self.of_run(recorder, mark, start, self.now).values():
                largest = max(largest, norm(w.wrench.force))
        print(f"holders_lockstep: two hands: particle {last.released_particles[0]} let go at "
              f"t = {last.released_times[0]:.3f} s; largest wrench read {largest:.1f} N "
              f"(limit {limit:.1f} N)")
        self.assertLessEqual(largest, limit * (1 + 1e-9))
        self.assertGreater(largest, 0.1 * limit)  # it was pulled hard first
        said = self.wait_until(lambda: diagnostic_value(self.diagnostics, mark, "hold let go"),
                               "/diagnostics saying the hold let go")
        self.assertIn("max_force", said)

    def test_3_a_clock_that_loops_back(self):
        # a bag's 2 s of the hand at 30 Hz, then played again from its start (rosbag --loop)
        mark = time.monotonic()
        bag_start = self.restart(WORKLOAD)
        every = 33_333_333
        sent = [bag_start]

        def frames(now):
            out = []
            while sent[0] + every <= now:
                sent[0] += every
                out.append(("hand", sent[0], hand((sent[0] - bag_start) * 1e-9)))
            return out
        listener_buffer = tf2_ros.Buffer()
        listener = tf2_ros.TransformListener(listener_buffer)
        self.advance(2000, frames)
        self.settle()
        old_end = self.now
        # the jump: the clock and the hand start the bag again
        jump_wall = time.monotonic()
        self.now = bag_start
        sent[0] = bag_start
        self.advance(1200, frames)
        self.settle()
        new_end = self.now
        # after the first message of the new epoch, none of the old (per topic: one connection)
        def check(messages, stamp_of_message, what):
            seen_new = False
            for m in messages:
                t = stamp_of_message(m)
                if t is None:
                    continue
                if t <= new_end and t < old_end - 700_000_000:
                    seen_new = True
                elif seen_new:
                    self.fail(f"{what} stamped {t * 1e-9:.3f} s (the old epoch) after the jump")
            self.assertTrue(seen_new, f"no {what} of the new epoch")
        check(self.states.since(jump_wall), lambda m: m.header.stamp.to_nsec(), "~state")
        check(self.tf.since(jump_wall),
              lambda m: next((t.header.stamp.to_nsec() for t in m.transforms
                              if t.child_frame_id == "particle_0"), None), "/tf")
        # a sim-time tf2 listener holds the new epoch's frames, not the old epoch's last
        newest = listener_buffer.lookup_transform("world", "particle_0", rospy.Time(0))
        self.assertLessEqual(newest.header.stamp.to_nsec(), new_end)
        self.assertGreater(newest.header.stamp.to_nsec(), new_end - 500_000_000)
        listener.unregister()
        # the held end at its holder again within the lag: every state of the new epoch from
        # the latency (and a tick) after the jump on
        states = {m.header.stamp.to_nsec(): m for m in self.states.since(jump_wall)
                  if m.header.stamp.to_nsec() <= new_end}
        lag = max(s.anchor_lag for s in states.values())
        back = [(t, s) for t, s in states.items() if t >= bag_start + round(lag * 1e9) + TICK_NS]
        self.assertGreater(len(back), 500)
        worst = max(math.dist(point(s.positions[0]), hand((t - bag_start) * 1e-9)) for t, s in back)
        first = min(t for t, _ in back)
        print(f"holders_lockstep: loop: back at the hand from {(first - bag_start) * 1e-9:.3f} s "
              f"into the new epoch (latency {lag:.4f} s), within {worst:.3g} m after")
        self.assertLess(worst, 1e-4)
        value = diagnostic_value(self.diagnostics, jump_wall, "frame_anchor 0")
        self.assertIn("re-placed after the clock went back 1", value)

    def test_4_jumps_and_a_flicker_are_teleports(self):
        base = lambda t: (0.2 * math.sin(0.2 * math.pi * t), 0.2 * math.cos(0.2 * math.pi * t)
                          - 0.2, 1.5)  # 0.126 m/s

        def offset(t):
            x, y = 0.0, 0.0
            if t >= 0.6:
                x += 0.45
            if t >= 1.0:
                y += 1.2
            if t >= 1.4:
                x += 2.0
            return x, y
        every = 10_000_000  # 100 Hz
        flicker = [1.8 + k * 0.01 for k in range(1, 11)]  # 10 broadcasts, 0.6 m apart
        jumped = lambda t: (lambda b, o, f: (b[0] + o[0], b[1] + o[1] + f, b[2]))(
            base(t), offset(t), 0.6 if any(abs(t - s) < 1e-6 for s in flicker[::2]) else 0.0)
        figures = {}
        for name, path in (("reference", base), ("jumps", jumped)):
            start, end, mark = self.run_hand(WORKLOAD, 2.2, every, path)
            states = self.of_run(self.states, mark, start, end)
            figures[name] = ({round((t - start) * 1e-6): s.kinetic_energy for t, s in states.items()},
                             states[max(states)], mark)
        reference, _, _ = figures["reference"]
        kinetic, last, mark = figures["jumps"]
        self.assertEqual(last.holder_teleports[0], 3 + 10)
        value = diagnostic_value(self.diagnostics, mark, "frame_anchor 0")
        self.assertIn("teleports 13 (last 0.6", value)
        # the kinetic energy after each jump (its first 20 ms) as without it
        worst = 0.0
        for at_ms in (600, 1000, 1400) + tuple(round(s * 1000) for s in flicker):
            for ms in range(at_ms, at_ms + 20):
                if ms in kinetic and ms in reference:
                    worst = max(worst, abs(kinetic[ms] - reference[ms]) / reference[ms])
        print(f"holders_lockstep: 13 teleports; kinetic energy after each within {worst:.3g} of "
              f"the run without them")
        self.assertLess(worst, 0.01)
        for ms, value in kinetic.items():
            self.assertLess(value, 10 * max(reference.values()), f"energy injected at {ms} ms")

    def test_5_attach_a_swinging_tip_where_it_is(self):
        self.restart("chain")  # 5 particles swinging from a pin
        gripper = (0.3, 0.0, 0.5)
        every = 33_333_333  # 30 Hz
        sent = [self.now]

        def frames(now):
            out = []
            while sent[0] + every <= now:
                sent[0] += every
                out.append(("gripper", sent[0], gripper))
            return out
        self.advance(700, frames)
        self.settle()
        swinging = self.states.latest()
        self.assertGreater(norm(swinging.velocities[4]), 0.1, "the tip swings")
        # refusals, naming the field; nothing changed
        for request, field in (((9, "gripper", Vector3(), True), "particle"),
                               ((0, "gripper", Vector3(), True), "particle"),  # the pin's
                               ((4, "never_seen", Vector3(), True), "frame"),
                               ((4, "", Vector3(), True), "frame"),
                               ((4, "gripper", Vector3(2e6, 0, 0), False), "offset")):
            reply = self.attach(*request)
            self.assertFalse(reply.success, request)
            self.assertTrue(reply.message.startswith(field), reply.message)
        self.assertEqual(list(self.states.latest().held_particles), [])
        # grabbed where it is: the state the reply's stamp names. The call is answered once tf
        # holds the gripper's pose at the state's stamp, which a 30 Hz broadcast reaches within
        # a broadcast interval: the clock (and the gripper) go on meanwhile, as a robot's would
        mark = time.monotonic()
        replies = []
        call = threading.Thread(target=lambda: replies.append(self.attach(4, "gripper",
                                                                          Vector3(), True)))
        call.start()
        while call.is_alive():
            self.advance(1, frames)
        reply = replies[0]
        self.assertTrue(reply.success, reply.message)
        self.assertEqual(reply.moved, 0.0)
        at = self.wait_until(lambda: next((s for _, s in self.states.items
                                           if s.header.stamp == reply.stamp), None),
                             "the state at the reply's stamp")
        held = point(at.positions[4])
        self.advance(800, frames)
        self.settle()
        after = [s for s in self.states.since(mark) if s.header.stamp > reply.stamp]
        self.assertGreater(len(after), 300)
        worst = max(math.dist(point(s.positions[4]), held) for s in after)
        print(f"holders_lockstep: attach of a swinging tip: held within {worst:.3g} m of where "
              f"it was at the reply's stamp over {len(after)} states")
        self.assertLess(worst, 1e-6)
        self.assertEqual(list(after[-1].held_particles), [4])


if __name__ == "__main__":
    rostest.rosrun("constrained_particles", "holders_lockstep", HoldersLockstepTest)
