#!/usr/bin/env python3
"""Republishes sensor_msgs/PointCloud from ~input as sensor_msgs/PointCloud2 on ~output
(float32 x, y, z and intensity, the layout of RosAria's sonar_pointcloud2), same header.
For sim_sonar_cloud2.test: rbpf_slam_node must take a PointCloud2 sonar_cloud."""
import struct

import rospy
from sensor_msgs.msg import PointCloud, PointCloud2, PointField

FIELDS = [PointField("x", 0, PointField.FLOAT32, 1), PointField("y", 4, PointField.FLOAT32, 1),
          PointField("z", 8, PointField.FLOAT32, 1),
          PointField("intensity", 12, PointField.FLOAT32, 1)]


def main():
    rospy.init_node("cloud2_relay")
    publisher = rospy.Publisher(rospy.get_param("~output", "sonar_cloud2"), PointCloud2,
                                queue_size=50)

    def relay(cloud):
        out = PointCloud2()
        out.header = cloud.header
        out.height, out.width = 1, len(cloud.points)
        out.fields = FIELDS
        out.is_bigendian = False
        out.point_step = 16
        out.row_step = 16 * out.width
        out.is_dense = True
        out.data = b"".join(struct.pack("<ffff", p.x, p.y, p.z, 1.0) for p in cloud.points)
        publisher.publish(out)

    rospy.Subscriber(rospy.get_param("~input", "sonar_cloud"), PointCloud, relay, queue_size=50)
    rospy.spin()


if __name__ == "__main__":
    main()
