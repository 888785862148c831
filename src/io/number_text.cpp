#include "rbpf_slam/io/number_text.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace rbpf_slam {
namespace io {

NumberText parseNumberText(const std::string& token, double* value) {
  if (token.empty()) return NumberText::kNotNumber;
  char* end = nullptr;
  errno = 0;
  const double parsed = std::strtod(token.c_str(), &end);
  if (end != token.c_str() + token.size()) return NumberText::kNotNumber;
  // ERANGE: an overflow gives +-HUGE_VAL (not finite); an underflow a subnormal or zero, which
  // is the nearest double to what was written.
  if (!std::isfinite(parsed) || (errno == ERANGE && std::fabs(parsed) >= 1.0)) {
    return NumberText::kNotFinite;
  }
  *value = parsed;
  return NumberText::kFinite;
}

}  // namespace io
}  // namespace rbpf_slam
