#include "rbpf_slam/ros/param_loader.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <string>

namespace rbpf_slam {
namespace rosbridge {
namespace {

/// Keys that ROS tools may place in a node's private namespace without the user asking for
/// them (tf_prefix by old launch files); they are not part of the config.
constexpr const char* kRosAddedKeys[] = {"tf_prefix"};

bool isRosAddedKey(const std::string& key) {
  for (const char* added : kRosAddedKeys) {
    if (key == added) return true;
  }
  return false;
}

std::string doubleText(double value) {
  if (std::isnan(value)) return ".nan";
  if (std::isinf(value)) return value > 0.0 ? ".inf" : "-.inf";
  std::ostringstream out;
  out.precision(std::numeric_limits<double>::max_digits10);
  out << value;
  return out.str();
}

}  // namespace

YAML::Node paramsToYaml(const XmlRpc::XmlRpcValue& value) {
  // XmlRpcValue's accessors are non-const; work on a copy (cheap: it is reference-counted
  // only for arrays and structs, and configs are small).
  XmlRpc::XmlRpcValue v = value;
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return YAML::Node(static_cast<bool>(v) ? "true" : "false");
    case XmlRpc::XmlRpcValue::TypeInt:
      return YAML::Node(std::to_string(static_cast<int>(v)));
    case XmlRpc::XmlRpcValue::TypeDouble:
      return YAML::Node(doubleText(static_cast<double>(v)));
    case XmlRpc::XmlRpcValue::TypeString:
      return YAML::Node(static_cast<std::string>(v));
    case XmlRpc::XmlRpcValue::TypeArray: {
      YAML::Node sequence(YAML::NodeType::Sequence);
      for (int i = 0; i < v.size(); ++i) sequence.push_back(paramsToYaml(v[i]));
      return sequence;
    }
    case XmlRpc::XmlRpcValue::TypeStruct: {
      YAML::Node map(YAML::NodeType::Map);
      for (auto it = v.begin(); it != v.end(); ++it) map[it->first] = paramsToYaml(it->second);
      return map;
    }
    default:
      // Dates, binary and invalid values have no config meaning; keep them visible as text
      // so the loader reports the key instead of silently dropping it.
      return YAML::Node(v.toXml());
  }
}

io::SlamConfig loadConfigFromParams(const ros::NodeHandle& private_nh,
                                    const std::set<std::string>& node_parameters) {
  const std::string ns = private_nh.getNamespace();
  std::string source = "~ parameters (" + ns + ")";
  XmlRpc::XmlRpcValue file_param;
  if (private_nh.getParam(kConfigFileParam, file_param)) {
    if (file_param.getType() != XmlRpc::XmlRpcValue::TypeString) {
      throw io::ConfigError(source + ": " + kConfigFileParam + " must be a file path");
    }
    const std::string file = static_cast<std::string>(file_param);
    if (!file.empty()) {
      // The file the launch file loaded, read as offline_slam reads it: a key written twice
      // (which rosparam keeps once, silently) or any other error is named with the file.
      io::loadSlamConfig(file);
      source = "~ parameters (" + ns + ", loaded from " + file + ")";
    }
  }
  XmlRpc::XmlRpcValue tree;
  YAML::Node root(YAML::NodeType::Map);
  if (private_nh.getParam("", tree)) {
    if (tree.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
      throw io::ConfigError(source + ": " + ns + " must be a namespace of parameters");
    }
    for (auto it = tree.begin(); it != tree.end(); ++it) {
      if (isRosAddedKey(it->first) || node_parameters.count(it->first) ||
          it->first == kConfigFileParam) {
        continue;
      }
      root[it->first] = paramsToYaml(it->second);
    }
  }
  return io::parseSlamConfig(root, source);
}

}  // namespace rosbridge
}  // namespace rbpf_slam
