#pragma once
// A flat JSON object written one field per line ("key": value), as summary.json and
// evaluate's output are: strings escaped, non-finite numbers written as null, so that every
// file a tool writes parses whatever a message or a diverged run holds.

#include <sstream>
#include <string>

namespace rbpf_slam {
namespace io {

/// A JSON number: 9 significant digits (as %.9g, whatever the C locale), or null for NaN and
/// infinities (JSON has no literal for them).
std::string jsonNumber(double value);

/// A JSON string literal: quotes, backslashes and control characters escaped.
std::string jsonString(const std::string& text);

/// Builds one JSON object, fields in the order added.
class JsonObjectWriter {
 public:
  JsonObjectWriter& number(const std::string& key, double value);
  JsonObjectWriter& integer(const std::string& key, long long value);
  /// For the full range of unsigned values (a seed).
  JsonObjectWriter& unsignedInteger(const std::string& key, unsigned long long value);
  JsonObjectWriter& boolean(const std::string& key, bool value);
  JsonObjectWriter& string(const std::string& key, const std::string& value);
  /// A value already in JSON (a nested object or array).
  JsonObjectWriter& raw(const std::string& key, const std::string& json);
  /// "{\n  \"key\": value,\n ...\n}\n" ("{}\n" without fields).
  std::string str() const;

 private:
  std::ostringstream fields_;
  bool empty_ = true;
};

}  // namespace io
}  // namespace rbpf_slam
