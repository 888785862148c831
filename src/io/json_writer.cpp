#include "rbpf_slam/io/json_writer.h"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace rbpf_slam {
namespace io {

std::string jsonNumber(double value) {
  if (!std::isfinite(value)) return "null";
  // to_chars ignores the C locale (a "," decimal separator would not be JSON).
  char buffer[32];
  const std::to_chars_result r =
      std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::general, 9);
  return std::string(buffer, r.ptr);
}

std::string jsonString(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buffer[8];
          std::snprintf(buffer, sizeof(buffer), "\\u%04x", static_cast<unsigned char>(c));
          out += buffer;
        } else {
          out += c;  // UTF-8 bytes pass through
        }
    }
  }
  return out + "\"";
}

JsonObjectWriter& JsonObjectWriter::raw(const std::string& key, const std::string& json) {
  fields_ << (empty_ ? "" : ",\n") << "  " << jsonString(key) << ": " << json;
  empty_ = false;
  return *this;
}

JsonObjectWriter& JsonObjectWriter::number(const std::string& key, double value) {
  return raw(key, jsonNumber(value));
}

JsonObjectWriter& JsonObjectWriter::integer(const std::string& key, long long value) {
  return raw(key, std::to_string(value));
}

JsonObjectWriter& JsonObjectWriter::unsignedInteger(const std::string& key,
                                                    unsigned long long value) {
  return raw(key, std::to_string(value));
}

JsonObjectWriter& JsonObjectWriter::boolean(const std::string& key, bool value) {
  return raw(key, value ? "true" : "false");
}

JsonObjectWriter& JsonObjectWriter::string(const std::string& key, const std::string& value) {
  return raw(key, jsonString(value));
}

std::string JsonObjectWriter::str() const {
  return empty_ ? "{}\n" : "{\n" + fields_.str() + "\n}\n";
}

}  // namespace io
}  // namespace rbpf_slam
