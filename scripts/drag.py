#!/usr/bin/python3
"""Drags a particle from the command line, as rviz would with the mouse.

  drag.py PARTICLE X Y Z [--node /simulator] [--seconds 1] [--hold 3]

Turns the node's ~interactive on (dynamic_reconfigure), then sends the interactive-marker
feedback rviz sends when a user grabs particle PARTICLE's marker on ~grab and moves it: a
MOUSE_DOWN where the particle is, pose updates moving the marker to (X, Y, Z) [m, in the node's
fixed frame] over --seconds, then holds it there for --hold seconds (0 = until Ctrl-C) and lets
go (MOUSE_UP; on Ctrl-C too). While held, the particle is pulled towards the marker by a
critically damped spring (docs/node.md, "Grab, drag and push"). ~interactive stays on afterwards.
"""
import argparse
import signal
import sys
import time

import rospy
from constrained_particles.msg import SimState
from dynamic_reconfigure.client import Client
from visualization_msgs.msg import InteractiveMarkerFeedback

RATE = 30.0  # feedback messages per second, about what rviz sends while dragging [Hz]


def feedback(node_frame, particle, event, position):
    f = InteractiveMarkerFeedback()
    f.header.frame_id = node_frame
    f.header.stamp = rospy.Time.now()
    f.client_id = "/drag_py"
    f.marker_name = str(particle)
    f.control_name = "drag"
    f.event_type = event
    f.pose.position.x, f.pose.position.y, f.pose.position.z = position
    f.pose.orientation.w = 1.0
    return f


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("particle", type=int)
    parser.add_argument("x", type=float)
    parser.add_argument("y", type=float)
    parser.add_argument("z", type=float)
    parser.add_argument("--node", default="/simulator")
    parser.add_argument("--frame", default=None,
                        help="the node's ~fixed_frame (default: read from the parameter server)")
    parser.add_argument("--seconds", type=float, default=1.0, help="time to move the marker")
    parser.add_argument("--hold", type=float, default=3.0, help="then hold it (0 = until Ctrl-C)")
    args = parser.parse_args(rospy.myargv()[1:])
    # our own Ctrl-C and SIGTERM: the MOUSE_UP below must still go out (rospy's handler would
    # stop it first), and a shell's background job starts with SIGINT ignored
    def interrupt(*_):
        raise KeyboardInterrupt
    signal.signal(signal.SIGINT, interrupt)
    signal.signal(signal.SIGTERM, interrupt)
    rospy.init_node("drag", anonymous=True, disable_signals=True)
    node = "/" + args.node.strip("/")
    if args.frame is None:
        args.frame = rospy.get_param(node + "/fixed_frame", "world")
    Client(node, timeout=30.0).update_configuration({"interactive": True})
    state = rospy.wait_for_message(node + "/state", SimState, timeout=30.0)
    if not 0 <= args.particle < len(state.positions):
        sys.exit("drag.py: particle %d: the scene has %d particles"
                 % (args.particle, len(state.positions)))
    publisher = rospy.Publisher(node + "/grab/feedback", InteractiveMarkerFeedback, queue_size=10)
    deadline = time.monotonic() + 10.0
    while publisher.get_num_connections() == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)  # the markers are made on the node's next publish
    start = state.positions[args.particle]
    start = (start.x, start.y, start.z)
    target = (args.x, args.y, args.z)
    publisher.publish(feedback(args.frame, args.particle, InteractiveMarkerFeedback.MOUSE_DOWN,
                               start))
    steps = max(1, int(args.seconds * RATE))
    rate = rospy.Rate(RATE)
    try:
        for k in range(1, steps + 1):
            s = k / steps
            position = tuple(a + s * (b - a) for a, b in zip(start, target))
            publisher.publish(feedback(args.frame, args.particle,
                                       InteractiveMarkerFeedback.POSE_UPDATE, position))
            rate.sleep()
        held_until = time.monotonic() + args.hold if args.hold > 0 else float("inf")
        while time.monotonic() < held_until:
            publisher.publish(feedback(args.frame, args.particle,
                                       InteractiveMarkerFeedback.POSE_UPDATE, target))
            rate.sleep()
    except KeyboardInterrupt:
        pass
    finally:
        # let go (the node also lets go of a marker nobody has held for 2 s)
        publisher.publish(feedback(args.frame, args.particle,
                                   InteractiveMarkerFeedback.MOUSE_UP, target))
        time.sleep(0.2)
        rospy.signal_shutdown("released")


if __name__ == "__main__":
    main()
