#pragma once
// Turns the node's private ROS parameters into the same SlamConfig a YAML file gives, through
// the same loader, so unknown keys and out-of-range values are errors here too.

#include <ros/node_handle.h>
#include <xmlrpcpp/XmlRpcValue.h>
#include <yaml-cpp/yaml.h>

#include <set>
#include <string>

#include "rbpf_slam/io/slam_config.h"

namespace rbpf_slam {
namespace rosbridge {

/// The YAML equivalent of a parameter value (struct -> map, array -> sequence, scalars as
/// their text; non-finite doubles as .inf / .nan so the range checks reject them).
YAML::Node paramsToYaml(const XmlRpc::XmlRpcValue& value);

/// The private parameter naming the config file a launch file loaded into the namespace
/// (`<param name="config_file" value="$(arg config)"/>` beside the `<rosparam load>`): not a
/// config key. When set, that file must itself be a valid config (io::loadSlamConfig: a key
/// written twice, which rosparam silently keeps once, is refused naming the file), and
/// errors in the parameters name it.
constexpr const char* kConfigFileParam = "config_file";

/// Parses the whole private parameter tree of private_nh with io::parseSlamConfig. Parameters
/// that ROS tools add to a private namespace are skipped. Throws io::ConfigError naming the
/// namespace (and the config_file, when set) and the key.
/// `node_parameters` are the node's own private parameters (not config keys), also skipped.
io::SlamConfig loadConfigFromParams(const ros::NodeHandle& private_nh,
                                    const std::set<std::string>& node_parameters = {});

}  // namespace rosbridge
}  // namespace rbpf_slam
