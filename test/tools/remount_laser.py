#!/usr/bin/env python3
"""Writes a copy of a robot bag whose laser is mounted upside down (its frame rolled by pi
about its x axis on /tf_static, each scan's beams reversed so that every beam still sees the
same point of the world) and whose scans name their frame with a leading '/', as old drivers
do. SLAM on the copy must give the map and path of the original.

    remount_laser.py IN.bag OUT.bag            # upside down, as above
    remount_laser.py --pitch-deg D IN.bag OUT.bag
        # instead: the laser frame pitched by D degrees on /tf_static, scans unchanged (a
        # tilted laser that rbpf_slam uses as if level, and must say so)
"""
import math
import sys

import rosbag

SCAN = "sensor_msgs/LaserScan"
TF = "tf2_msgs/TFMessage"


def roll_pi(q):
    """q * (roll pi): the frame turned half a turn about its own x axis."""
    # (w, x, y, z) * (0, 1, 0, 0)
    w, x, y, z = q.w, q.x, q.y, q.z
    q.w, q.x, q.y, q.z = -x, w, z, -y


def pitch(q, degrees):
    """q * (pitch by degrees): the frame turned about its own y axis."""
    h = 0.5 * math.radians(degrees)
    c, s = math.cos(h), math.sin(h)
    w, x, y, z = q.w, q.x, q.y, q.z
    # (w, x, y, z) * (c, 0, s, 0)
    q.w, q.x, q.y, q.z = w * c - y * s, x * c - z * s, y * c + w * s, z * c + x * s


def main(argv):
    pitch_deg = None
    if len(argv) == 5 and argv[1] == "--pitch-deg":
        pitch_deg = float(argv[2])
        argv = [argv[0]] + argv[3:]
    if len(argv) != 3:
        sys.stderr.write(__doc__)
        return 2
    scan_frames = set()
    with rosbag.Bag(argv[1]) as bag:
        for _, msg, _ in bag.read_messages():
            if msg._type == SCAN:
                scan_frames.add(msg.header.frame_id.lstrip("/"))
    if not scan_frames:
        sys.stderr.write("remount_laser.py: no sensor_msgs/LaserScan in %s\n" % argv[1])
        return 1
    rolled = 0
    with rosbag.Bag(argv[1]) as bag, rosbag.Bag(argv[2], "w") as out:
        for topic, msg, t in bag.read_messages():
            if msg._type == TF and topic.lstrip("/") == "tf_static":
                for transform in msg.transforms:
                    if transform.child_frame_id.lstrip("/") in scan_frames:
                        if pitch_deg is None:
                            roll_pi(transform.transform.rotation)
                        else:
                            pitch(transform.transform.rotation, pitch_deg)
                        rolled += 1
            elif msg._type == SCAN and pitch_deg is None:
                n = len(msg.ranges)
                angle_max = msg.angle_min + (n - 1) * msg.angle_increment
                # Beam i of the copy is beam n-1-i of the original: at -(its angle) upside down.
                msg.angle_min, msg.angle_max = -angle_max, -msg.angle_min
                msg.ranges = list(reversed(msg.ranges))
                msg.intensities = list(reversed(msg.intensities))
                msg.header.frame_id = "/" + msg.header.frame_id.lstrip("/")
            out.write(topic, msg, t)
    if rolled == 0:
        sys.stderr.write("remount_laser.py: the laser frame is not on /tf_static\n")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
