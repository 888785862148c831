namespace rbpf_slam { namespace ros_layer { int placeholder_ros = 0; } }
