#!/usr/bin/python3
"""rviz framed on a simulator's scene.

  rviz_view.py [--node /simulator] [--config config/simulator.rviz] [--hide-panels]
               [--timeout 30] [--write-only FILE]

Waits for the node's ~view (constrained_particles/SceneView, latched: the scene's region of
interest), writes a copy of the rviz config whose orbit camera looks at the region's centre from
far enough to hold its whole bounding sphere (distance = 1.05 radius / sin(fov / 2)), whose point
cloud draws particles at the node's particle size and whose topics are the node's, then runs
rviz on it (replacing this process, so roslaunch stops rviz as it would stop this script).
The camera is set once, at start: after a scene change, rviz's own camera tools (or a restart)
reframe it. --write-only writes the config and exits (no rviz). --hide-panels hides rviz's
docks, menus and image panels (rviz --fullscreen: headless screenshots).
"""
import argparse
import math
import os
import sys

import rospy
import yaml
from constrained_particles.msg import SceneView

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_CONFIG = os.path.join(HERE, "..", "config", "simulator.rviz")
# the shipped config's topics are /simulator/...: another node's replace that prefix
SHIPPED_NODE = "/simulator"
# the drawn particle's least diameter, a share of the region's radius [1]
POINT_SIZE_FLOOR = 0.006


def framed(config, view, node, hide_panels):
    """The rviz config (a dict, from its YAML) with camera, point size and topics set."""
    manager = config["Visualization Manager"]
    camera = manager["Views"]["Current"]
    fov = float(camera.get("Field of View", 0.785))
    camera["Focal Point"] = {"X": view.center.x, "Y": view.center.y, "Z": view.center.z}
    camera["Distance"] = 1.05 * max(view.radius, 1e-3) / math.sin(0.5 * fov)
    camera["Near Clip Distance"] = max(1e-4, 1e-3 * view.radius)
    manager["Global Options"]["Fixed Frame"] = view.header.frame_id or "world"
    for display in manager["Displays"]:
        if display.get("Class") == "rviz/PointCloud2":
            # the node's particle size, but at least a few pixels at this distance (1,000
            # particles on 5 mm links would be dust)
            display["Size (m)"] = max(view.particle_size, POINT_SIZE_FLOOR * view.radius)
        for key in ("Topic", "Marker Topic", "Update Topic", "Image Topic"):
            topic = display.get(key)
            if isinstance(topic, str) and topic.startswith(SHIPPED_NODE + "/"):
                display[key] = node + topic[len(SHIPPED_NODE):]
    if hide_panels:
        # rviz --fullscreen hides the docks; an Image display would bring its own panel back
        manager["Displays"] = [d for d in manager["Displays"] if d.get("Class") != "rviz/Image"]
    return config


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--node", default=SHIPPED_NODE, help="the simulator node's name")
    parser.add_argument("--config", default=DEFAULT_CONFIG, help="the rviz config to start from")
    parser.add_argument("--hide-panels", action="store_true",
                        help="rviz full screen, without docks or image panels")
    parser.add_argument("--timeout", type=float, default=30.0,
                        help="seconds to wait for the node's ~view")
    parser.add_argument("--write-only", metavar="FILE", help="write the framed config and exit")
    args, _ = parser.parse_known_args(rospy.myargv()[1:])
    node = "/" + args.node.strip("/")
    rospy.init_node("rviz_view", anonymous=True, disable_signals=True)
    try:
        view = rospy.wait_for_message(node + "/view", SceneView, timeout=args.timeout)
    except rospy.ROSException:
        sys.exit("rviz_view.py: no %s/view within %g s: is the simulator running?"
                 % (node, args.timeout))
    with open(args.config) as f:
        config = framed(yaml.safe_load(f), view, node, args.hide_panels)
    if args.write_only:
        path = args.write_only
    else:
        # one file per node, rewritten at each start (rviz reads it while it runs)
        home = os.environ.get("ROS_HOME", os.path.join(os.path.expanduser("~"), ".ros"))
        os.makedirs(home, exist_ok=True)
        path = os.path.join(home, "constrained_particles%s.rviz" % node.replace("/", "_"))
    with open(path, "w") as f:
        yaml.safe_dump(config, f, default_flow_style=False, sort_keys=False)
    rospy.signal_shutdown("config written")
    if args.write_only:
        print("wrote %s (scene '%s', radius %.3g m)" % (path, view.scenario, view.radius))
        return
    os.execvp("rviz", ["rviz", "-d", path] + (["--fullscreen"] if args.hide_panels else []))


if __name__ == "__main__":
    main()
