#include "rbpf_slam/ros/param_loader.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
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

/// A private string parameter, "" when unset; io::ConfigError naming it when not a string.
std::string stringParam(const ros::NodeHandle& private_nh, const char* key,
                        const std::string& source) {
  XmlRpc::XmlRpcValue value;
  if (!private_nh.getParam(key, value)) return "";
  if (value.getType() != XmlRpc::XmlRpcValue::TypeString) {
    throw io::ConfigError(source + ": " + key + " must be a string");
  }
  return static_cast<std::string>(value);
}

/// True for a plain integer with a leading zero or a 0x/0b prefix, which the offline loader
/// refuses. rosparam's YAML 1.1 reads 010 as octal 8, 0x10 and 0b10 as hex and binary, and 09 as
/// a string: the node would otherwise run with another value than offline_slam on the same file.
bool nonDecimalInteger(const YAML::Node& node) {
  if (!node.IsScalar() || node.Tag() != "?") return false;  // quoted: a string
  const std::string& t = node.Scalar();
  std::size_t i = (!t.empty() && (t[0] == '+' || t[0] == '-')) ? 1 : 0;
  if (t.size() < i + 2 || t[i] != '0') return false;
  const char next = t[i + 1];
  if (next == 'x' || next == 'X' || next == 'b' || next == 'B') return true;
  return std::all_of(t.begin() + static_cast<long>(i), t.end(),
                     [](char c) { return c >= '0' && c <= '9'; });
}

/// The first key repeated in one mapping of `node` (yaml-cpp keeps both copies), or the first
/// integer written in another base than decimal, with where.
bool findRepeatedKeyOrNonDecimal(const YAML::Node& node, const std::string& where,
                                 std::string* found) {
  if (nonDecimalInteger(node)) {
    *found = (where.empty() ? std::string("the top level") : where) + " = " + node.Scalar() +
             " is not a decimal integer (rosparam reads a leading zero as octal, or as a "
             "string when it is not octal like 09, and 0x/0b as hex/binary; offline_slam "
             "refuses it): write it without the leading zero or prefix";
    return true;
  }
  if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      const std::string item = where + "[" + std::to_string(i) + "]";
      if (findRepeatedKeyOrNonDecimal(node[i], item, found)) return true;
    }
  }
  if (!node.IsMap()) return false;
  std::set<std::string> seen;
  for (const auto& item : node) {
    const std::string key = item.first.IsScalar() ? item.first.Scalar() : std::string("?");
    if (!seen.insert(key).second) {
      *found = "key '" + key + "' appears more than once " +
               (where.empty() ? std::string("at the top level") : "in " + where);
      return true;
    }
    const std::string inner = where.empty() ? key : where + "." + key;
    if (findRepeatedKeyOrNonDecimal(item.second, inner, found)) return true;
  }
  return false;
}

/// io::ConfigError "SOURCE: key 'K' appears more than once in SECTION" for the first key
/// repeated in one mapping of the YAML `text`, "SOURCE: KEY = 010 is not a decimal integer ..."
/// for the first integer in another base (or "SOURCE: not valid YAML: ...").
void requireDistinctKeysAndDecimalIntegers(const std::string& text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw io::ConfigError(source + ": not valid YAML: " + e.what());
  }
  std::string found;
  if (findRepeatedKeyOrNonDecimal(root, "", &found)) throw io::ConfigError(source + ": " + found);
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
  const std::string file = stringParam(private_nh, kConfigFileParam, source);
  if (!file.empty()) source = "~ parameters (" + ns + ", loaded from " + file + ")";
  // The file's text as roslaunch read it (`textfile`, resolved where `<rosparam load>` is, so a
  // relative path or a file on another machine is found): a key written twice, which rosparam
  // keeps once without a word, is refused naming the file.
  const std::string text = stringParam(private_nh, kConfigTextParam, source);
  if (!text.empty()) requireDistinctKeysAndDecimalIntegers(text, file.empty() ? source : file);
  XmlRpc::XmlRpcValue tree;
  YAML::Node root(YAML::NodeType::Map);
  if (private_nh.getParam("", tree)) {
    if (tree.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
      throw io::ConfigError(source + ": " + ns + " must be a namespace of parameters");
    }
    for (auto it = tree.begin(); it != tree.end(); ++it) {
      if (isRosAddedKey(it->first) || node_parameters.count(it->first) ||
          it->first == kConfigFileParam || it->first == kConfigTextParam) {
        continue;
      }
      root[it->first] = paramsToYaml(it->second);
    }
  }
  return io::parseSlamConfig(root, source);
}

}  // namespace rosbridge
}  // namespace rbpf_slam
