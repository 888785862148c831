#pragma once
// One range check (and one list check) for every options struct of the core, so that a bad
// configuration value gets the same message wherever it is read:
// "<section>.<key> = <value> is out of range [lo, hi]", "<key> = '<word>' is not one of: ...".

#include <string>
#include <vector>

namespace rbpf_slam {
namespace core {

/// Shortest decimal form of value, as the messages print it (0.5, 1e+06, inf, nan).
std::string formatNumber(double value);

/// Throws std::invalid_argument("<name> = <value> is out of range [lo, hi]") unless
/// lo <= value <= hi (strict at an open end, printed with a parenthesis; an infinite hi is
/// printed open). NaN always throws. `name` carries the section: "scan_matching.max_range_m".
void requireRange(const std::string& name, double value, double lo, double hi,
                  bool lo_open = false, bool hi_open = false);

/// Throws std::invalid_argument("<name> = '<value>' is not one of: a, b") unless value is one
/// of allowed: the same check for every option that takes one word from a list.
void requireOneOf(const std::string& name, const std::string& value,
                  const std::vector<std::string>& allowed);

}  // namespace core
}  // namespace rbpf_slam
