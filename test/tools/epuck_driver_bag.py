#!/usr/bin/env python3
"""Rewrites a simulated e-puck bag (worlds/yatim_epuck.yaml: every infrared reading on `ir`,
frames base_link and ir_0 .. ir_7) the way GCtronic's e-puck driver (epuck_driver_cpp)
publishes a real robot:

- each proximity sensor on its own topic, /proximity0 .. /proximity7 (sensor_msgs/Range);
- frames prefixed by the robot's name: NAME/base_link, NAME/base_prox0 .. NAME/base_prox7
  (odom keeps its name), in /tf, /tf_static and every message header;
- with --driver-ranges, the driver's Range fields: field_of_view 0.26 rad, min_range
  0.005 m, max_range 0.05 m, and the range clamped to [min_range, max_range], so that no
  obstacle reads max_range (the driver turns its raw values into metres this way).

Without --driver-ranges the readings are unchanged, so a run on the rewritten bag with
sonar_topic listing the eight topics and base_frame NAME/base_link must match a run on the
original bag. Messages keep their stamps; the rewritten bag keeps the original order of the
messages (a few microseconds are added to the receive times of messages received together).

  epuck_driver_bag.py IN.bag OUT.bag [--name epuck2_robot_0] [--driver-ranges]
"""
import argparse
import copy
import re
import sys

import rosbag
import rospy

DRIVER_FOV = 0.26
DRIVER_MIN = 0.005
DRIVER_MAX = 0.05


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("input")
    parser.add_argument("output")
    parser.add_argument("--name", default="epuck2_robot_0", help="the driver's epuck2_name")
    parser.add_argument("--driver-ranges", action="store_true",
                        help="the driver's field of view, range limits and clamping")
    args = parser.parse_args()

    def frame(name):
        name = name.lstrip("/")
        sensor = re.fullmatch(r"ir_(\d+)", name)
        if sensor:
            return "%s/base_prox%s" % (args.name, sensor.group(1))
        if name == "base_link":
            return args.name + "/base_link"
        return name

    counts = {}
    last_time, same = None, 0
    with rosbag.Bag(args.input) as bag_in, rosbag.Bag(args.output, "w") as bag_out:
        for topic, msg, t in bag_in.read_messages():
            same = same + 1 if t == last_time else 0
            last_time = t
            received = t + rospy.Duration(0, 1000 * same)
            if topic in ("/tf", "/tf_static"):
                msg = copy.deepcopy(msg)
                for transform in msg.transforms:
                    transform.header.frame_id = frame(transform.header.frame_id)
                    transform.child_frame_id = frame(transform.child_frame_id)
            elif hasattr(msg, "header"):
                msg = copy.deepcopy(msg)
                msg.header.frame_id = frame(msg.header.frame_id)
                if hasattr(msg, "child_frame_id"):
                    msg.child_frame_id = frame(msg.child_frame_id)
            if topic == "/ir":
                sensor = re.fullmatch(r".*/base_prox(\d+)", msg.header.frame_id)
                if not sensor:
                    sys.exit("%s: an /ir reading in frame '%s', not ir_N" %
                             (args.input, msg.header.frame_id))
                topic = "/proximity" + sensor.group(1)
                if args.driver_ranges:
                    msg.field_of_view = DRIVER_FOV
                    msg.min_range = DRIVER_MIN
                    msg.max_range = DRIVER_MAX
                    msg.range = min(max(msg.range, DRIVER_MIN), DRIVER_MAX)
            counts[topic] = counts.get(topic, 0) + 1
            bag_out.write(topic, msg, received)
    print("%s: %s" % (args.output, ", ".join("%s %d" % kv for kv in sorted(counts.items()))))


if __name__ == "__main__":
    main()
