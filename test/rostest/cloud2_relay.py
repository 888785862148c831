#!/usr/bin/env python3
"""Republishes sensor_msgs/PointCloud from ~input as sensor_msgs/PointCloud2 on ~output
(float32 x, y, z and intensity, the layout of RosAria's sonar_pointcloud2), same header.
For sim_sonar_cloud2.test: rbpf_slam_node must take a PointCloud2 sonar_cloud."""
import os
import sys

import rospy
from sensor_msgs.msg import PointCloud, PointCloud2

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
from cloud_to_cloud2 import to_cloud2  # noqa: E402  (the converter the script test uses)


def main():
    rospy.init_node("cloud2_relay")
    publisher = rospy.Publisher(rospy.get_param("~output", "sonar_cloud2"), PointCloud2,
                                queue_size=50)
    rospy.Subscriber(rospy.get_param("~input", "sonar_cloud"), PointCloud,
                     lambda cloud: publisher.publish(to_cloud2(cloud)), queue_size=50)
    rospy.spin()


if __name__ == "__main__":
    main()
