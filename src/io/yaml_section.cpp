#include "rbpf_slam/io/yaml_section.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

namespace rbpf_slam {
namespace io {
namespace {

std::string describe(const YAML::Node& node) {
  if (node.IsScalar()) return node.Scalar();
  std::ostringstream out;
  out << node;
  return out.str();
}

std::string rangeText(double min, double max) {
  std::ostringstream out;
  out << "[" << min << ", " << max << "]";
  return out.str();
}

}  // namespace

bool decimalInteger(const YAML::Node& node, bool* negative, unsigned long long* magnitude) {
  if (!node.IsScalar()) return false;
  const std::string& text = node.Scalar();
  std::size_t i = 0;
  *negative = false;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) *negative = text[i++] == '-';
  if (i == text.size()) return false;
  if (text[i] == '0' && i + 1 < text.size()) return false;  // 010: octal to some readers
  *magnitude = 0;
  constexpr unsigned long long kMax = std::numeric_limits<unsigned long long>::max();
  for (; i < text.size(); ++i) {
    if (text[i] < '0' || text[i] > '9') return false;
    const unsigned digit = static_cast<unsigned>(text[i] - '0');
    if (*magnitude > (kMax - digit) / 10) return false;
    *magnitude = *magnitude * 10 + digit;
  }
  return true;
}

YamlSection::YamlSection(const YAML::Node& node, std::string source, std::string path)
    : node_(node), source_(std::move(source)), path_(std::move(path)) {
  if (node_ && !node_.IsNull() && !node_.IsMap()) {
    throw ConfigError(source_ + ": " + (path_.empty() ? "the top level" : path_) +
                      " must be a map of key: value");
  }
}

std::string YamlSection::where(const std::string& key) const {
  return source_ + ": " + (path_.empty() ? key : path_ + "." + key);
}

bool YamlSection::has(const std::string& key) const { return node_ && node_.IsMap() && node_[key]; }

YAML::Node YamlSection::child(const std::string& key) {
  read_.insert(key);
  // An absent key must read as undefined (false), not as a defined null node.
  if (!node_ || !node_.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  const YAML::Node n = node_[key];
  return n ? n : YAML::Node(YAML::NodeType::Undefined);
}

void YamlSection::read(const std::string& key, double* value, double min, double max) {
  const YAML::Node n = child(key);
  if (!n) return;
  double parsed;
  try {
    parsed = n.as<double>();
  } catch (const YAML::Exception&) {
    throw ConfigError(where(key) + " = " + describe(n) +
                      " is not a number (or too large for one: beyond 1.8e308)");
  }
  if (!std::isfinite(parsed)) throw ConfigError(where(key) + " = " + describe(n) + " is not finite");
  if (parsed < min || parsed > max) {
    throw ConfigError(where(key) + " = " + describe(n) + " is out of range " +
                      rangeText(min, max));
  }
  *value = parsed;
}

void YamlSection::read(const std::string& key, int* value, int min, int max) {
  const YAML::Node n = child(key);
  if (!n) return;
  long long parsed = 0;
  bool negative = false;
  unsigned long long magnitude = 0;
  if (!decimalInteger(n, &negative, &magnitude) ||
      magnitude > static_cast<unsigned long long>(std::numeric_limits<long long>::max())) {
    throw ConfigError(where(key) + " = " + describe(n) +
                      " is not an integer (decimal digits, no leading zero)");
  }
  parsed = negative ? -static_cast<long long>(magnitude) : static_cast<long long>(magnitude);
  if (parsed < min || parsed > max) {
    throw ConfigError(where(key) + " = " + describe(n) + " is out of range " +
                      rangeText(min, max));
  }
  *value = static_cast<int>(parsed);
}

void YamlSection::read(const std::string& key, unsigned long* value) {
  const YAML::Node n = child(key);
  if (!n) return;
  // The whole unsigned range (an ensemble member's seed, which needs all 64 bits, can be given
  // back as a config seed); a negative number is named as such.
  bool negative = false;
  unsigned long long magnitude = 0;
  if (!decimalInteger(n, &negative, &magnitude) ||
      magnitude > std::numeric_limits<unsigned long>::max()) {
    throw ConfigError(where(key) + " = " + describe(n) +
                      " is not a non-negative integer (decimal digits, no leading zero)");
  }
  if (negative && magnitude > 0) {
    throw ConfigError(where(key) + " = " + describe(n) + " must be >= 0");
  }
  *value = static_cast<unsigned long>(magnitude);
}

void YamlSection::read(const std::string& key, bool* value) {
  const YAML::Node n = child(key);
  if (!n) return;
  try {
    *value = n.as<bool>();
  } catch (const YAML::Exception&) {
    throw ConfigError(where(key) + " = " + describe(n) + " is not true or false");
  }
}

void YamlSection::read(const std::string& key, std::string* value,
                       const std::vector<std::string>& allowed) {
  const YAML::Node n = child(key);
  if (!n) return;
  if (!n.IsScalar()) throw ConfigError(where(key) + " must be a string");
  const std::string parsed = n.Scalar();
  if (!allowed.empty()) {
    bool ok = false;
    std::string list;
    for (const auto& a : allowed) {
      ok = ok || a == parsed;
      list += (list.empty() ? "" : ", ") + a;
    }
    if (!ok) throw ConfigError(where(key) + " = '" + parsed + "' is not one of: " + list);
  }
  *value = parsed;
}

void YamlSection::read(const std::string& key, std::vector<double>* value) {
  const YAML::Node n = child(key);
  if (!n) return;
  if (!n.IsSequence()) throw ConfigError(where(key) + " must be a list of numbers");
  std::vector<double> parsed;
  for (const auto& item : n) {
    try {
      parsed.push_back(item.as<double>());
    } catch (const YAML::Exception&) {
      throw ConfigError(where(key) + " contains " + describe(item) + ", not a number");
    }
    if (!std::isfinite(parsed.back())) throw ConfigError(where(key) + " contains a non-finite value");
  }
  *value = parsed;
}

void YamlSection::readNames(const std::string& key, std::vector<std::string>* value) {
  const YAML::Node n = child(key);
  if (!n) return;
  if (!n.IsScalar() && !n.IsSequence()) {
    throw ConfigError(where(key) + " must be a name or a list of names");
  }
  std::vector<YAML::Node> items;
  if (n.IsScalar()) {
    items.push_back(n);
  } else {
    for (const YAML::Node& item : n) items.push_back(item);
  }
  std::vector<std::string> parsed;
  for (const YAML::Node& item : items) {
    if (!item.IsScalar()) {
      throw ConfigError(where(key) + " contains " + describe(item) + ", not a name");
    }
    const std::string name = item.Scalar();
    if (name.empty()) throw ConfigError(where(key) + " contains an empty name");
    // roslaunch's <param value="[a, b]"/> (or "a, b") is one string: no ROS name holds these.
    if (name.find_first_of("[], \t") != std::string::npos) {
      throw ConfigError(where(key) + " = '" + name +
                        "' is not a name (a list written as one string?); in a launch file give "
                        "a list with <rosparam param=\"" +
                        key + "\">[a, b]</rosparam>");
    }
    // "a" and "/a" are one topic in the root namespace: subscribed twice, every message would
    // count twice.
    const auto bare = [](const std::string& text) {
      return text.front() == '/' ? text.substr(1) : text;
    };
    for (const std::string& earlier : parsed) {
      if (bare(earlier) == bare(name)) {
        throw ConfigError(where(key) + " names '" + bare(name) + "' twice");
      }
    }
    parsed.push_back(name);
  }
  if (parsed.empty()) throw ConfigError(where(key) + " is an empty list (at least one name)");
  *value = parsed;
}

YamlSection YamlSection::section(const std::string& key) {
  const YAML::Node n = child(key);
  if (n && !n.IsMap() && !n.IsNull()) throw ConfigError(where(key) + " must be a map");
  return YamlSection(n ? n : YAML::Node(YAML::NodeType::Undefined), source_,
                     path_.empty() ? key : path_ + "." + key);
}

void YamlSection::finish() const {
  if (!node_ || !node_.IsMap()) return;
  const std::string where = path_.empty() ? std::string("at the top level") : "in " + path_;
  std::string unknown;
  bool any_unknown = false;
  std::set<std::string> seen;
  for (const auto& item : node_) {
    if (!item.first.IsScalar()) {
      throw ConfigError(source_ + ": a key that is not a plain name " + where);
    }
    const std::string key = item.first.Scalar();
    // yaml-cpp keeps both copies of a repeated key and reads the first: an edit of the second
    // would be silently ignored.
    if (!seen.insert(key).second) {
      throw ConfigError(source_ + ": key '" + key + "' appears more than once " + where);
    }
    if (!read_.count(key)) {
      unknown += (any_unknown ? ", " : "") + (key.empty() ? std::string("''") : key);
      any_unknown = true;
    }
  }
  if (any_unknown) {
    throw ConfigError(source_ + ": unknown key(s) " +
                      (path_.empty() ? std::string("at the top level") : "in " + path_) + ": " +
                      unknown);
  }
}

void applyOverride(YAML::Node* root, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw ConfigError("--set '" + assignment + "' must look like key=value or a.b=value");
  }
  const std::string path = assignment.substr(0, eq);
  const std::string value = assignment.substr(eq + 1);
  std::vector<std::string> keys;
  std::stringstream stream(path);
  for (std::string key; std::getline(stream, key, '.');) keys.push_back(key);
  if (path.back() == '.' || std::find(keys.begin(), keys.end(), "") != keys.end()) {
    throw ConfigError("--set '" + assignment + "': an empty key in '" + path + "'");
  }
  if (!root->IsMap() && !root->IsNull()) {
    throw ConfigError("--set '" + assignment + "': the config's top level is not a map of keys");
  }
  YAML::Node parsed;
  try {
    parsed = YAML::Load(value);
  } catch (const YAML::Exception& e) {
    throw ConfigError("--set '" + assignment + "': the value is not valid YAML: " + e.msg);
  }
  // yaml-cpp node assignment rebinds handles, so walk with explicit copies of children.
  std::vector<YAML::Node> chain{*root};
  std::string walked;
  for (size_t i = 0; i + 1 < keys.size(); ++i) {
    walked += (walked.empty() ? "" : ".") + keys[i];
    YAML::Node next = chain.back()[keys[i]];
    if (!next || next.IsNull()) {
      chain.back()[keys[i]] = YAML::Node(YAML::NodeType::Map);
      next = chain.back()[keys[i]];
    } else if (!next.IsMap()) {
      throw ConfigError("--set '" + assignment + "': '" + walked + "' is not a section");
    }
    chain.push_back(next);
  }
  chain.back()[keys.back()] = parsed;
}

}  // namespace io
}  // namespace rbpf_slam
