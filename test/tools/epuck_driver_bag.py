#!/usr/bin/env python3
"""Rewrites a simulated e-puck bag (worlds/yatim_epuck.yaml: every infrared reading on `ir`,
frames base_link and ir_0 .. ir_7) the way GCtronic's e-puck driver (epuck_driver_cpp)
publishes a real robot:

- each proximity sensor on its own topic, /proximity0 .. /proximity7 (sensor_msgs/Range);
- frames prefixed by the robot's name: NAME/base_link, NAME/base_prox0 .. NAME/base_prox7
  (odom keeps its name), in /tf, /tf_static and every message header (the simulator sends the
  mounts once on /tf_static; see --driver-tf for the driver's way);
- with --driver-ranges, the driver's Range fields: field_of_view 0.26 rad, min_range
  0.005 m, max_range 0.05 m, and the range clamped to [min_range, max_range], so that no
  obstacle reads max_range (the driver turns its raw values into metres this way).

- with --driver-tf, the driver's timing: every cycle it stamps the eight readings with the
  clock as it publishes them, then sends NAME/base_link -> NAME/base_proxN on /tf (not
  /tf_static) and then odom -> NAME/base_link, so each reading is stamped a little before the
  transforms that place it (here 2 ms before the cycle's odometry, 0.1 ms apart; the mounts
  1 ms before it), and the first cycle's readings come before any odometry.

Without --driver-ranges and --driver-tf the readings are unchanged, so a run on the rewritten
bag with sonar_topic listing the eight topics and base_frame NAME/base_link must match a run on
the original bag. Otherwise messages keep their stamps; the rewritten bag keeps the original
order of the messages (a few microseconds are added to the receive times of messages received
together).

  epuck_driver_bag.py IN.bag OUT.bag [--name epuck2_robot_0] [--driver-ranges] [--driver-tf]
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
    parser.add_argument("--driver-tf", action="store_true",
                        help="the driver's timing: mounts on /tf every cycle, readings stamped "
                             "before the cycle's transforms")
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
    mounts = []  # --driver-tf: the prox frames' transforms, sent with each cycle's odometry
    with rosbag.Bag(args.input) as bag_in, rosbag.Bag(args.output, "w") as bag_out:
        for topic, msg, t in bag_in.read_messages():
            same = same + 1 if t == last_time else 0
            last_time = t
            received = t + rospy.Duration(0, 1000 * same)
            if args.driver_tf and topic == "/tf_static":
                mounts = [copy.deepcopy(x) for x in msg.transforms
                          if re.fullmatch(r"/?ir_\d+", x.child_frame_id)]
                kept = [x for x in msg.transforms if x not in mounts and
                        not re.fullmatch(r"/?ir_\d+", x.child_frame_id)]
                if not kept:
                    continue
                msg = copy.deepcopy(msg)
                msg.transforms = kept
            if args.driver_tf and topic == "/tf" and mounts:
                stamp = msg.transforms[0].header.stamp
                sent = copy.deepcopy(msg)
                sent.transforms = copy.deepcopy(mounts)
                for transform in sent.transforms:
                    transform.header.stamp = stamp - rospy.Duration(0, 1000000)
                    transform.header.frame_id = frame(transform.header.frame_id)
                    transform.child_frame_id = frame(transform.child_frame_id)
                bag_out.write("/tf", sent, received - rospy.Duration(0, 1000000))
                counts["/tf (mounts)"] = counts.get("/tf (mounts)", 0) + 1
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
                if args.driver_tf:
                    index = int(sensor.group(1))
                    early = rospy.Duration(0, 2000000 - 100000 * index)
                    msg.header.stamp = msg.header.stamp - early
                    received = t - early
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
