#pragma once
// When the odometry (the odom -> base transform) was received, so that a stretch without
// odometry (a real gap: the increment across it is a guess) can be told from a stretch without
// sensor frames while the odometry kept coming (e.g. 30-80 s without a landmark sighting).

#include <cstddef>
#include <limits>
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

  /// A stretch between two consecutive odometry stamps.
  struct Silence {
    double length = -1.0;  // s; negative: unknown (no stamp was ever recorded)
    double start = 0.0;    // the stamp it began after (t0 when none came before), which names
                           // it even before it ends
  };
  /// The longest stretch without odometry that overlaps [t0, t1]: the stamps inside, the last
  /// one before t0 and the first one after t1 are joined in order, so a stretch may reach
  /// before t0 and past t1 (a pose interpolated at t0 or t1 is only as good as the odometry
  /// around it). Where no stamp lies before t0 (after t1) the stretch starts at t0 (ends at
  /// t1). Stretches starting at or before `counted_start` (already dealt with) do not count.
  Silence longestSilence(double t0, double t1,
                         double counted_start = -std::numeric_limits<double>::infinity()) const;

  /// Forgets every stamp before the last one at or before `stamp` (still needed to bracket it).
  void forgetBefore(double stamp);
  void clear();

 private:
  std::size_t capacity_;
  std::set<double> stamps_;
  // The newest stamp dropped for capacity: the odometry came until then (no silence before).
  double evicted_until_ = -std::numeric_limits<double>::infinity();
};

}  // namespace core
}  // namespace rbpf_slam
