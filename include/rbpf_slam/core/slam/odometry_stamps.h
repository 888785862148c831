#pragma once
// When the odometry (the odom -> base transform) was received, so that a stretch without
// odometry (a real gap: the increment across it is a guess) can be told from a stretch without
// sensor frames while the odometry kept coming (e.g. 30-80 s without a landmark sighting).

#include <cstddef>
#include <set>

namespace rbpf_slam {
namespace core {

class OdometryStamps {
 public:
  /// At most this many stamps are kept; the oldest go first (a node that gets odometry but
  /// no frames must not grow without bound).
  explicit OdometryStamps(std::size_t capacity = 200000);

  /// Records one odometry stamp (s). Any order; duplicates and non-finite stamps are ignored.
  void add(double stamp);
  bool empty() const { return stamps_.empty(); }
  std::size_t size() const { return stamps_.size(); }

  /// The longest time (s) within [t0, t1] not bracketed by two consecutive odometry stamps:
  /// the stamps inside, the last one before t0 and the first one after t1 are joined in
  /// order; where none lies before t0 (after t1), the interval reaches to t0 (t1). A pose
  /// interpolated at t1 is only as good as the odometry around it, hence the stamp after t1.
  /// Negative when no stamp was ever recorded (unknown: the caller falls back to its own rule).
  double longestSilence(double t0, double t1) const;

  /// Forgets every stamp before the last one at or before `stamp` (still needed to bracket it).
  void forgetBefore(double stamp);
  void clear() { stamps_.clear(); }

 private:
  std::size_t capacity_;
  std::set<double> stamps_;
};

}  // namespace core
}  // namespace rbpf_slam
