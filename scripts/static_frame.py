#!/usr/bin/python3
"""Puts a still tf frame on /tf_static: a stand-in for a robot's link that does not move.

Broadcasts NAME in --parent (default world, REP 105's fixed frame for the simulator) at X Y Z [m],
turned by --roll, --pitch, --yaw [rad] (fixed axes x, y, z, as URDF's rpy), then waits until
stopped (a static transform lasts while its broadcaster lives).

Usage: rosrun constrained_particles static_frame.py NAME X Y Z [--yaw 0.3] [--parent world]
"""
import argparse
import math

import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped


def quaternion(roll, pitch, yaw):
    """(x, y, z, w) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name", help="the frame's name")
    parser.add_argument("xyz", type=float, nargs=3, help="its origin in the parent [m]")
    parser.add_argument("--parent", default="world")
    for axis in ("roll", "pitch", "yaw"):
        parser.add_argument(f"--{axis}", type=float, default=0.0, help="[rad]")
    args = parser.parse_args(rospy.myargv()[1:])
    rospy.init_node(f"static_frame_{args.name}".replace("/", "_"), anonymous=True)
    t = TransformStamped()
    t.header.stamp = rospy.Time.now()
    t.header.frame_id = args.parent
    t.child_frame_id = args.name
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = args.xyz
    (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
     t.transform.rotation.w) = quaternion(args.roll, args.pitch, args.yaw)
    broadcaster = tf2_ros.StaticTransformBroadcaster()
    broadcaster.sendTransform(t)
    rospy.spin()


if __name__ == "__main__":
    main()
