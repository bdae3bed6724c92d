#!/usr/bin/python3
"""Moves tf frame `hand` along a figure-eight and prints what the rope pulls it with.

The example of launch/hold_the_rope.launch: a stand-in for a robot's gripper frame. It broadcasts
`hand` in `world` (REP 105's fixed frame for the simulator) at --rate Hz, stamped now, on the
figure-eight x = A sin(w t), y = A sin(2 w t) / 2 about --centre, and once a second prints the
anchor wrench the simulator publishes for the held particle: the force [N] a force/torque sensor
in the hand would read, in the hand's frame.

Usage: rosrun constrained_particles hand.py [--amplitude 0.4] [--period 4] [--rate 30]
                                            [--centre 0 0 1.5] [--node /simulator] [--particle 0]
"""
import argparse
import math
import sys
import time

import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped, WrenchStamped


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--amplitude", type=float, default=0.4, help="A, the eight's half-width [m]")
    parser.add_argument("--period", type=float, default=4.0, help="one figure-eight [s]")
    parser.add_argument("--rate", type=float, default=30.0, help="broadcasts per second [Hz]")
    parser.add_argument("--centre", type=float, nargs=3, default=[0.0, 0.0, 1.5], help="[m]")
    parser.add_argument("--node", default="/simulator", help="the simulator node's name")
    parser.add_argument("--particle", type=int, default=0, help="the held particle")
    args = parser.parse_args(rospy.myargv(sys.argv)[1:])
    if not (args.amplitude >= 0.0 and args.period > 0.0 and args.rate > 0.0):
        parser.error("--amplitude must be >= 0, --period and --rate > 0")
    rospy.init_node("hand")
    broadcaster = tf2_ros.TransformBroadcaster()  # tf2_ros: the standard /tf publisher
    latest = {}
    rospy.Subscriber(f"{args.node}/anchor_wrench/particle_{args.particle}", WrenchStamped,
                     lambda msg: latest.update(wrench=msg), queue_size=1)
    omega = 2.0 * math.pi / args.period
    while rospy.Time.now().is_zero() and not rospy.is_shutdown():
        time.sleep(0.05)  # under /use_sim_time, until the first /clock (wall-clock polling)
    start = rospy.Time.now()
    last_print = start
    rate = rospy.Rate(args.rate)
    while not rospy.is_shutdown():
        now = rospy.Time.now()
        t = (now - start).to_sec()
        msg = TransformStamped()
        msg.header.stamp = now
        msg.header.frame_id = "world"
        msg.child_frame_id = "hand"
        msg.transform.translation.x = args.centre[0] + args.amplitude * math.sin(omega * t)
        msg.transform.translation.y = args.centre[1] + 0.5 * args.amplitude * math.sin(2 * omega * t)
        msg.transform.translation.z = args.centre[2]
        msg.transform.rotation.w = 1.0
        broadcaster.sendTransform(msg)
        if (now - last_print).to_sec() >= 1.0 and "wrench" in latest:
            wrench = latest.pop("wrench")  # only what came since the last line: never a stale one
            f = wrench.wrench.force
            print(f"t = {t:6.2f} s  rope pulls hand with ({f.x:+.3f}, {f.y:+.3f}, {f.z:+.3f}) N "
                  f"in {wrench.header.frame_id}", flush=True)
            last_print = now
        try:
            rate.sleep()
        except rospy.ROSTimeMovedBackwardsException:
            pass


if __name__ == "__main__":
    try:
        main()
    except rospy.ROSInterruptException:
        pass
