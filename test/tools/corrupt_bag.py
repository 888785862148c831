#!/usr/bin/env python3
"""Writes a corrupted copy of a laser bag (sensor_msgs/LaserScan on /scan, tf odom -> base_link
on /tf), with one fault class per window of the bag's duration, so that tests can check that
the node and the offline runner survive each one and recover after it:

  fraction 0.10-0.20  invalid beams: NaN, +inf, -inf in a third of the beams, one all-NaN scan
  fraction 0.25       a scan duplicated (same stamp) and a copy stamped 5 s in the past
  fraction 0.35-0.45  tf gap: no odom -> base_link for this span (scans keep coming)
  fraction 0.50       a scan with an empty frame_id and one in a frame tf does not know
  fraction 0.55       a scan whose angle_increment is NaN (malformed header)
  fraction 0.60       the odometry jumps 3 m sideways and stays shifted
  end                 the first 20% of the bag again with its own stamps (a loop: time goes back)

usage: corrupt_bag.py IN.bag OUT.bag     (prints the fault windows as JSON on stdout)
"""
import copy
import json
import math
import sys

import rosbag


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
            if topic == "/scan":
                if at(0.10) <= st < at(0.20):
                    ranges = list(msg.ranges)
                    bad = [float("nan"), float("inf"), float("-inf")]
                    for i in range(0, len(ranges), 3):
                        ranges[i] = bad[(i // 3) % 3]
                    if "all_nan" not in done:
                        ranges = [float("nan")] * len(ranges)
                        done.add("all_nan")
                    msg.ranges = ranges
                if st >= at(0.25) and "stale" not in done:
                    done.add("stale")
                    out.write(topic, msg, t)
                    old = copy.deepcopy(msg)
                    old.header.stamp.secs -= 5
                    out.write(topic, old, t)
                if st >= at(0.50) and "frames" not in done:
                    done.add("frames")
                    for frame in ("", "no_such_laser"):
                        odd = copy.deepcopy(msg)
                        odd.header.frame_id = frame
                        out.write(topic, odd, t)
                if st >= at(0.55) and "malformed" not in done:
                    done.add("malformed")
                    odd = copy.deepcopy(msg)
                    odd.angle_increment = float("nan")
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
