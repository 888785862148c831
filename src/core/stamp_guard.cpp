#include "rbpf_slam/core/stamp_guard.h"

#include <algorithm>
#include <cmath>

namespace rbpf_slam {
namespace core {

StampGuard::Verdict StampGuard::check(const std::string& pair, double stamp, double now) {
  const bool clock_known = now > 0.0;
  // Once a restart showed the clock right, it alone is the reference (the newest taken could
  // creep ahead by a day a glitch at a time).
  if (clock_trusted_ && clock_known) {
    if (stamp > now + max_ahead_s_) return Verdict::kRefuseAhead;
  } else if (newest_ > 0.0 && stamp > std::max(newest_, now) + max_ahead_s_) {
    // Compared with the later of the newest and the clock: a forward jump of both (a second bag
    // days later, a clock set by network time) is taken.
    return Verdict::kRefuseAhead;
  }
  const auto it = newest_of_pair_.find(pair);
  if (it != newest_of_pair_.end() && stamp == it->second) return Verdict::kRepeat;
  if (it == newest_of_pair_.end() || !clock_known) return Verdict::kTake;
  const double newest = it->second;
  if (stamp < newest - max_ahead_s_ && newest > now + max_ahead_s_ &&
      std::fabs(stamp - now) <= max_ahead_s_) {
    clock_trusted_ = true;
    return Verdict::kRestart;
  }
  return Verdict::kTake;
}

void StampGuard::taken(const std::string& pair, double stamp) {
  newest_ = std::max(newest_, stamp);
  double& newest = newest_of_pair_[pair];
  newest = std::max(newest, stamp);
}

}  // namespace core
}  // namespace rbpf_slam
