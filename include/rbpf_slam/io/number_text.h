#pragma once
// One reading of a number written as text (log fields, TUM lines, tool options): the whole
// token must be a number; a subnormal or zero result is a number (strtod reports ERANGE on
// underflow too, which a plain errno check mistook for "not a number"), an overflow is not
// finite.

#include <string>

namespace rbpf_slam {
namespace io {

enum class NumberText {
  kFinite,     // a finite number (subnormals included)
  kNotFinite,  // a number, but inf, nan or beyond the double range (1e400)
  kNotNumber,  // empty, or characters left over
};

/// Parses the whole token with strtod; *value holds the result when kFinite.
NumberText parseNumberText(const std::string& token, double* value);

/// parseNumberText() == kFinite.
inline bool parseFiniteNumber(const std::string& token, double* value) {
  return parseNumberText(token, value) == NumberText::kFinite;
}

}  // namespace io
}  // namespace rbpf_slam
