#pragma once
// The stamps of the transforms on /tf, guarded against a far-off outlier. A non-static
// transform stamped far ahead makes tf2 drop every later real one of that pair (child frame) as
// older than it ("old data"), so one glitch would stop a node for good. Each transform is
// compared with the newest one taken so far (of any pair) and with the clock:
// - more than max_ahead_s after both: refused (an outlier while the stream is going);
// - the first transform of a pair has nothing of its own to be compared with and is taken. If
//   it was the outlier (more than max_ahead_s ahead of the clock), the pair's next ones come
//   more than max_ahead_s before it: the first of them that agrees with the clock (within
//   max_ahead_s of it) restarts the stream (the owner clears its tf buffer and takes it), and
//   from then on the clock is the reference: a transform more than max_ahead_s ahead of it is
//   refused, even as the first one after a clear.
// Pairs are told apart by their child frame, as tf2 does: one publisher whose clock is far
// ahead of this machine (its pairs stay consistent) is not undone by another that agrees with
// the clock (the node's own map -> odom). When the clock agrees with none of a pair's
// transforms (a robot computer without network time, a bag played without its clock), nothing
// is restarted.
// ROS-free, so that it is unit-tested without a roscore. Stamps and clock in seconds; a clock of
// 0 is unknown.

#include <map>
#include <string>

namespace rbpf_slam {
namespace core {

class StampGuard {
 public:
  enum class Verdict {
    kTake,         // hand it to tf (which may still refuse a repeat or old data)
    kRefuseAhead,  // far ahead of the newest taken (or of a trusted clock) and of the clock
    kRestart,      // the pair's newest was the outlier: clear tf, then take this one
    kRepeat,       // the pair's newest stamp again: tf2 would refuse it ("TF_REPEATED_DATA")
                   // (stamps as double s: two under ~0.25 us apart may count as one)
  };

  explicit StampGuard(double max_ahead_s = 86400.0) : max_ahead_s_(max_ahead_s) {}

  /// The verdict on a non-static transform of child frame `pair` stamped `stamp` at clock `now`.
  Verdict check(const std::string& pair, double stamp, double now);
  /// A transform of this pair with this stamp was taken by tf.
  void taken(const std::string& pair, double stamp);
  /// tf was cleared (a clock jump back, a restart): nothing taken yet.
  void clear() {
    newest_ = 0.0;
    newest_of_pair_.clear();
  }
  /// The newest stamp taken, of any pair (0: none since the start or the last clear).
  double newest() const { return newest_; }
  double maxAheadS() const { return max_ahead_s_; }

 private:
  const double max_ahead_s_;
  double newest_ = 0.0;
  std::map<std::string, double> newest_of_pair_;
  bool clock_trusted_ = false;  // a restart showed the clock right and a transform wrong
};

}  // namespace core
}  // namespace rbpf_slam
