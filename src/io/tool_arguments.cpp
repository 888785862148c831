#include "rbpf_slam/io/tool_arguments.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace rbpf_slam {
namespace io {

double parseNumber(const std::string& flag, const std::string& text, NumberRule rule) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  const bool parsed = !text.empty() && end == text.c_str() + text.size() && !std::isnan(value);
  const bool number = parsed && std::isfinite(value);
  if (rule == NumberRule::kNonNegative && !(number && value >= 0.0)) {
    throw std::invalid_argument(flag + " needs a non-negative number, got '" + text + "'");
  }
  if (rule == NumberRule::kPositive && !(number && value > 0.0)) {
    throw std::invalid_argument(flag + " needs a positive number, got '" + text + "'");
  }
  if (rule == NumberRule::kPositiveOrInfinite) {
    if (!(parsed && value > 0.0)) {
      throw std::invalid_argument(flag + " needs a positive number or inf, got '" + text + "'");
    }
    return value;
  }
  if (!number) throw std::invalid_argument(flag + " needs a number, got '" + text + "'");
  return value;
}

std::uint64_t parseUnsigned(const std::string& flag, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const unsigned long long value = std::strtoull(text.c_str(), &end, 10);
  if (text.empty() || !std::isdigit(static_cast<unsigned char>(text[0])) || errno == ERANGE ||
      end != text.c_str() + text.size()) {
    throw std::invalid_argument(flag + " needs a non-negative integer, got '" + text + "'");
  }
  return value;
}

std::string besideBag(const std::string& bag, const std::string& suffix) {
  const std::string ext = ".bag";
  const bool has_ext =
      bag.size() > ext.size() && bag.compare(bag.size() - ext.size(), ext.size(), ext) == 0;
  return (has_ext ? bag.substr(0, bag.size() - ext.size()) : bag) + suffix;
}

}  // namespace io
}  // namespace rbpf_slam
