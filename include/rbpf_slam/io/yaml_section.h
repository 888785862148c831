#pragma once
// Typed, tracked reads from one YAML map: every read is type-checked (numbers finite), may be
// range-checked, and every key that nobody read is reported, so a typo in a config is an
// error, not a silent default.

#include <yaml-cpp/yaml.h>

#include <limits>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace rbpf_slam {
namespace io {

/// A configuration problem; the message names the source, the key, the value and the range.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One YAML map being read. Sub-sections share the source name and report full key paths.
class YamlSection {
 public:
  YamlSection(const YAML::Node& node, std::string source, std::string path = "");

  bool has(const std::string& key) const;
  /// Reads an optional number; throws ConfigError if it is not a finite number or outside
  /// [min, max].
  void read(const std::string& key, double* value,
            double min = -std::numeric_limits<double>::infinity(),
            double max = std::numeric_limits<double>::infinity());
  void read(const std::string& key, int* value, int min = std::numeric_limits<int>::min(),
            int max = std::numeric_limits<int>::max());
  void read(const std::string& key, unsigned long* value);
  void read(const std::string& key, bool* value);
  /// Reads a string; when allowed is not empty the value must be one of them.
  void read(const std::string& key, std::string* value,
            const std::vector<std::string>& allowed = {});
  void read(const std::string& key, std::vector<double>* value);
  /// Reads one name or a list of them (e.g. topics): each a non-empty string, none twice, at
  /// least one.
  void readNames(const std::string& key, std::vector<std::string>* value);
  /// The sub-map under key (an empty section when absent).
  YamlSection section(const std::string& key);
  /// Throws ConfigError listing every key that was present but never read.
  void finish() const;

  /// "file: path.key", for messages.
  std::string where(const std::string& key) const;
  const std::string& source() const { return source_; }
  const YAML::Node& node() const { return node_; }

 private:
  YAML::Node child(const std::string& key);
  YAML::Node node_;
  std::string source_;
  std::string path_;
  std::set<std::string> read_;
  std::vector<std::shared_ptr<YamlSection>> children_;
};

/// A scalar written as a decimal integer (an optional sign, then digits only, no leading zero),
/// its sign and magnitude. False for anything else, or a magnitude beyond unsigned long long.
/// yaml-cpp alone would read 0x10 as 16 and 010 as octal 8; the node's parameters come through
/// rosparam, whose YAML 1.1 reads 010 as octal too: a leading zero is refused, not guessed.
bool decimalInteger(const YAML::Node& node, bool* negative, unsigned long long* magnitude);

/// Applies "a.b.c=value" overrides (as given with --set) to a YAML tree.
void applyOverride(YAML::Node* root, const std::string& assignment);

}  // namespace io
}  // namespace rbpf_slam
