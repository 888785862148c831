#include "rbpf_slam/core/slam/odometry_stamps.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <utility>

namespace rbpf_slam {
namespace core {

OdometryStamps::OdometryStamps(std::size_t capacity)
    : capacity_(std::max<std::size_t>(capacity, 2)) {}

void OdometryStamps::add(double stamp) {
  if (!std::isfinite(stamp)) return;
  stamps_.insert(stamp);
  while (stamps_.size() > capacity_) {
    evicted_until_ = std::max(evicted_until_, *stamps_.begin());
    stamps_.erase(stamps_.begin());
  }
}

OdometryStamps::Silence OdometryStamps::longestSilence(double t0, double t1,
                                                       double counted_start) const {
  Silence longest;
  if (stamps_.empty() && !std::isfinite(evicted_until_)) return longest;  // unknown
  if (t1 < t0) std::swap(t0, t1);
  longest.length = 0.0;
  longest.start = t0;
  auto it = stamps_.upper_bound(t0);  // first stamp after t0
  // The stretch starts at the last stamp at or before t0: kept, or the newest evicted one.
  double previous = it != stamps_.begin() ? std::min(*std::prev(it), t0) : t0;
  if (it == stamps_.begin() && std::isfinite(evicted_until_)) previous = evicted_until_;
  const auto consider = [&](double start, double end) {
    if (start > counted_start && end - start > longest.length) {
      longest.length = end - start;
      longest.start = start;
    }
  };
  for (; it != stamps_.end(); ++it) {
    consider(previous, *it);
    previous = *it;
    if (*it >= t1) return longest;  // the first stamp at or after t1 closes the window
  }
  consider(previous, t1);  // no odometry after t1 (yet)
  return longest;
}

void OdometryStamps::forgetBefore(double stamp) {
  auto it = stamps_.upper_bound(stamp);
  if (it == stamps_.begin()) return;
  stamps_.erase(stamps_.begin(), std::prev(it));
}

void OdometryStamps::clear() {
  stamps_.clear();
  evicted_until_ = -std::numeric_limits<double>::infinity();
}

}  // namespace core
}  // namespace rbpf_slam
