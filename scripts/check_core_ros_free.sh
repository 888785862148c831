#!/usr/bin/env bash
# Fails when a file of the ROS-free core (src/core, include/rbpf_slam/core) includes a ROS
# header. Called by the build before the core library compiles; args: SOURCE_DIR STAMP.
set -eu
src=$1 stamp=$2
pattern='#include *[<"](ros|tf|tf2|tf2_ros|tf2_geometry_msgs|sensor_msgs|nav_msgs|geometry_msgs|visualization_msgs|std_msgs|diagnostic_msgs|rosbag|rbpf_slam/ros|rbpf_slam/io|rbpf_slam/[A-Z][A-Za-z]*\.h)/?'
if hits=$(grep -rnE "$pattern" "$src/src/core" "$src/include/rbpf_slam/core" 2>/dev/null); then
  echo "error: the ROS-free core includes ROS or non-core headers:" >&2
  echo "$hits" >&2
  exit 1
fi
touch "$stamp"
