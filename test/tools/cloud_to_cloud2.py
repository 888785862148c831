#!/usr/bin/env python3
"""Writes a copy of a bag whose sensor_msgs/PointCloud messages on TOPIC are
sensor_msgs/PointCloud2 (float32 x, y, z and a float32 intensity channel, as RosAria's
sonar_pointcloud2 has), same header, same points; everything else is copied unchanged.

    cloud_to_cloud2.py IN.bag OUT.bag [TOPIC]        (TOPIC: /sonar_cloud)
"""
import struct
import sys

import rosbag
from sensor_msgs.msg import PointCloud2, PointField

FIELDS = [PointField("x", 0, PointField.FLOAT32, 1), PointField("y", 4, PointField.FLOAT32, 1),
          PointField("z", 8, PointField.FLOAT32, 1),
          PointField("intensity", 12, PointField.FLOAT32, 1)]


def to_cloud2(cloud):
    out = PointCloud2()
    out.header = cloud.header
    out.height, out.width = 1, len(cloud.points)
    out.fields = FIELDS
    out.is_bigendian = False
    out.point_step = 16
    out.row_step = out.point_step * out.width
    out.is_dense = True
    out.data = b"".join(struct.pack("<ffff", p.x, p.y, p.z, 1.0) for p in cloud.points)
    return out


def main(argv):
    if len(argv) not in (3, 4):
        sys.stderr.write(__doc__)
        return 2
    topic = argv[3] if len(argv) == 4 else "/sonar_cloud"
    converted = 0
    with rosbag.Bag(argv[1]) as bag, rosbag.Bag(argv[2], "w") as out:
        for name, msg, t in bag.read_messages():
            if name.lstrip("/") == topic.lstrip("/") and msg._type == "sensor_msgs/PointCloud":
                msg = to_cloud2(msg)
                converted += 1
            out.write(name, msg, t)
    if converted == 0:
        sys.stderr.write("cloud_to_cloud2.py: no sensor_msgs/PointCloud on %s in %s\n"
                         % (topic, argv[1]))
        return 1
    print("cloud_to_cloud2.py: %d clouds converted" % converted)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
