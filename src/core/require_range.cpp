#include "rbpf_slam/core/require_range.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace rbpf_slam {
namespace core {

std::string formatNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

void requireRange(const std::string& name, double value, double lo, double hi, bool lo_open,
                  bool hi_open) {
  const bool above_lo = lo_open ? value > lo : value >= lo;
  const bool below_hi = hi_open ? value < hi : value <= hi;
  if (above_lo && below_hi) return;
  throw std::invalid_argument(name + " = " + formatNumber(value) + " is out of range " +
                              (lo_open ? "(" : "[") + formatNumber(lo) + ", " + formatNumber(hi) +
                              (hi_open || std::isinf(hi) ? ")" : "]"));
}

void requireOneOf(const std::string& name, const std::string& value,
                  const std::vector<std::string>& allowed) {
  std::string list;
  for (const std::string& word : allowed) {
    if (word == value) return;
    list += (list.empty() ? "" : ", ") + word;
  }
  throw std::invalid_argument(name + " = '" + value + "' is not one of: " + list);
}

}  // namespace core
}  // namespace rbpf_slam
