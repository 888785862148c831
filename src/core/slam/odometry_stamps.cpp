#include "rbpf_slam/core/slam/odometry_stamps.h"

#include <algorithm>
#include <cmath>
#include <iterator>

namespace rbpf_slam {
namespace core {

OdometryStamps::OdometryStamps(std::size_t capacity)
    : capacity_(std::max<std::size_t>(capacity, 2)) {}

void OdometryStamps::add(double stamp) {
  if (!std::isfinite(stamp)) return;
  stamps_.insert(stamp);
  while (stamps_.size() > capacity_) stamps_.erase(stamps_.begin());
}

double OdometryStamps::longestSilence(double t0, double t1) const {
  if (stamps_.empty()) return -1.0;
  if (t1 < t0) std::swap(t0, t1);
  auto it = stamps_.upper_bound(t0);  // first stamp after t0
  double previous = t0;
  if (it != stamps_.begin()) previous = std::min(*std::prev(it), t0);
  double longest = 0.0;
  for (; it != stamps_.end(); ++it) {
    longest = std::max(longest, *it - previous);
    previous = *it;
    if (*it >= t1) return longest;  // the first stamp at or after t1 closes the window
  }
  return std::max(longest, t1 - previous);  // no odometry after t1 (yet)
}

void OdometryStamps::forgetBefore(double stamp) {
  auto it = stamps_.upper_bound(stamp);
  if (it == stamps_.begin()) return;
  stamps_.erase(stamps_.begin(), std::prev(it));
}

}  // namespace core
}  // namespace rbpf_slam
