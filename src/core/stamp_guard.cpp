#include "rbpf_slam/core/stamp_guard.h"

#include <algorithm>
#include <cmath>

namespace rbpf_slam {
namespace core {

StampGuard::Verdict StampGuard::check(double stamp, double now) {
  const bool clock_known = now > 0.0;
  if (newest_ <= 0.0) {  // nothing taken to compare with: only a clock known to be right
    return clock_trusted_ && clock_known && stamp > now + max_ahead_s_ ? Verdict::kRefuseAhead
                                                                       : Verdict::kTake;
  }
  // Compared with the later of the newest and the clock: a forward jump of both (a second bag
  // days later, a clock set by network time) is taken.
  if (stamp > std::max(newest_, now) + max_ahead_s_) return Verdict::kRefuseAhead;
  const bool newest_ahead_of_clock = clock_known && newest_ > now + max_ahead_s_;
  const bool agrees_with_clock = clock_known && std::fabs(stamp - now) <= max_ahead_s_;
  if (stamp < newest_ - max_ahead_s_ && newest_ahead_of_clock && agrees_with_clock) {
    clock_trusted_ = true;
    return Verdict::kRestart;
  }
  return Verdict::kTake;
}

void StampGuard::taken(double stamp) { newest_ = std::max(newest_, stamp); }

}  // namespace core
}  // namespace rbpf_slam
