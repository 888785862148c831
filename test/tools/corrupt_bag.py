#!/usr/bin/env python3
"""Writes a corrupted copy of a robot bag (sensor topics found by type, on any topic:
sensor_msgs/LaserScan, sensor_msgs/Range (sonar, infrared), sensor_msgs/PointCloud (sonar
cloud), rbpf_slam/FeatureArray; tf odom -> base_link on /tf), with one fault class per window of the bag's duration, so that tests
can check that the node and the offline runner survive each one and recover after it:

  fraction 0.10-0.20  invalid ranges: NaN, +inf, -inf in a third of the beams, one all-NaN
                      scan; sonar ranges NaN, +inf, -inf, 0, negative in turn; NaN cloud points;
                      features with NaN range, infinite or zero covariance, negative rho
  fraction 0.25       a message duplicated (same stamp) and a copy stamped 5 s in the past
  fraction 0.35-0.45  tf gap: no odom -> base_link for this span (sensors keep coming)
  fraction 0.50       a message with an empty frame_id and one in a frame tf does not know
  fraction 0.55       a malformed message: scan angle_increment NaN, sonar field_of_view NaN
  fraction 0.60       the odometry jumps 3 m sideways and stays shifted
  end                 the first 20% of the bag again with its own stamps (a loop: time goes back)

usage: corrupt_bag.py IN.bag OUT.bag     (prints the fault windows as JSON on stdout)
"""
import copy
import json
import math
import sys

import rosbag


SCAN, RANGE, CLOUD, FEATURES = ("sensor_msgs/LaserScan", "sensor_msgs/Range",
                                 "sensor_msgs/PointCloud", "rbpf_slam/FeatureArray")
SENSORS = (SCAN, RANGE, CLOUD, FEATURES)
BAD = [float("nan"), float("inf"), float("-inf"), 0.0, -1.0]


def invalidate(topic, msg, done):
    """The invalid-range fault, in place."""
    if msg._type == SCAN:
        ranges = list(msg.ranges)
        for i in range(0, len(ranges), 3):
            ranges[i] = BAD[(i // 3) % 3]
        if "all_nan" not in done:
            ranges = [float("nan")] * len(ranges)
            done.add("all_nan")
        msg.ranges = ranges
    elif msg._type == RANGE:
        count = len([d for d in done if d.startswith("sonar#")])
        done.add("sonar#%d" % count)
        msg.range = BAD[count % len(BAD)]
    elif msg._type == CLOUD:
        for i in range(0, len(msg.points), 2):
            msg.points[i].x = float("nan")
    else:
        for i, p in enumerate(msg.points):
            if i % 3 == 0:
                p.range = float("nan")
            elif i % 3 == 1:
                p.covariance = [float("inf"), 0.0, 0.0, 1.0]
            else:
                p.covariance = [0.0, 0.0, 0.0, 0.0]
        for line in msg.lines:
            line.rho = -line.rho
            line.theta += math.pi


def main():
    if len(sys.argv) != 3:
        sys.stderr.write(__doc__)
        return 2
    src, dst = sys.argv[1], sys.argv[2]
    bag = rosbag.Bag(src)
    t0, t1 = bag.get_start_time(), bag.get_end_time()
    span = t1 - t0
    at = lambda f: t0 + f * span
    windows = {"invalid_beams": [at(0.10), at(0.20)], "stale_stamps": [at(0.25), at(0.26)],
               "tf_gap": [at(0.35), at(0.45)], "bad_frames": [at(0.50), at(0.51)],
               "malformed_header": [at(0.55), at(0.56)], "odometry_jump": [at(0.60), at(0.61)],
               "loop": [t1, t1 + 0.2 * span]}
    done = set()
    head = []  # the first 20% again, for the loop
    with rosbag.Bag(dst, "w") as out:
        for topic, msg, t in bag.read_messages():
            st = t.to_sec()
            if st <= at(0.2):
                head.append((topic, msg, t))
            if topic in ("/tf", "tf") and at(0.35) <= st < at(0.45):
                kept = [x for x in msg.transforms if x.child_frame_id != "base_link"]
                if not kept:
                    continue
                msg.transforms = kept
            if topic in ("/tf", "tf") and st >= at(0.60):
                for x in msg.transforms:
                    if x.child_frame_id == "base_link":
                        x.transform.translation.y += 3.0
            if topic == "/odom" and st >= at(0.60):
                msg.pose.pose.position.y += 3.0
            if msg._type in SENSORS:
                if at(0.10) <= st < at(0.20):
                    invalidate(topic, msg, done)
                if st >= at(0.25) and "stale" + topic not in done:
                    done.add("stale" + topic)
                    out.write(topic, msg, t)
                    old = copy.deepcopy(msg)
                    old.header.stamp.secs -= 5
                    out.write(topic, old, t)
                if st >= at(0.50) and "frames" + topic not in done:
                    done.add("frames" + topic)
                    for frame in ("", "no_such_sensor"):
                        odd = copy.deepcopy(msg)
                        odd.header.frame_id = frame
                        out.write(topic, odd, t)
                if (st >= at(0.55) and "malformed" + topic not in done
                        and msg._type in (SCAN, RANGE)):
                    done.add("malformed" + topic)
                    odd = copy.deepcopy(msg)
                    if msg._type == SCAN:
                        odd.angle_increment = float("nan")
                    else:
                        odd.field_of_view = float("nan")
                    out.write(topic, odd, t)
            out.write(topic, msg, t)
        # The loop: the bag starts over, stamps and all (rosbag play -l, a restarted driver).
        shift = t1 + 1.0 - t0
        import rospy
        for topic, msg, t in head:
            if topic in ("/tf_static", "tf_static"):
                continue
            out.write(topic, msg, rospy.Time.from_sec(t.to_sec() + shift))
    print(json.dumps(windows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
