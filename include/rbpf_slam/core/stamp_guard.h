#pragma once
// The stamps of the transforms on /tf, guarded against a far-off outlier. A non-static
// transform stamped far ahead makes tf2 drop every later real one of that pair as older than it
// ("old data"), so one glitch would stop a node for good. Each transform is compared with the
// newest one taken so far and with the clock:
// - more than max_ahead_s after both: refused (an outlier while the stream is going);
// - the first transform has nothing to be compared with and is taken. If it was the outlier
//   (more than max_ahead_s ahead of the clock), the next ones come more than max_ahead_s before
//   it: the first of them that agrees with the clock (within max_ahead_s of it) restarts the
//   stream (the owner clears its tf buffer and takes it), and from then on the clock is the
//   reference, so that a transform more than max_ahead_s ahead of it is refused even as the
//   first one after a clear.
// When the clock agrees with none of them (a robot computer without network time, a bag played
// without its clock), nothing is restarted: the newest transform is the only reference.
// ROS-free, so that it is unit-tested without a roscore. Stamps and clock in seconds; a clock of
// 0 is unknown.

namespace rbpf_slam {
namespace core {

class StampGuard {
 public:
  enum class Verdict {
    kTake,         // hand it to tf (which may still refuse a repeat or old data)
    kRefuseAhead,  // far ahead of the newest taken (or of a trusted clock) and of the clock
    kRestart,      // the newest taken was the outlier: clear tf, then take this one
  };

  explicit StampGuard(double max_ahead_s = 86400.0) : max_ahead_s_(max_ahead_s) {}

  /// The verdict on a non-static transform stamped `stamp` at clock `now`.
  Verdict check(double stamp, double now);
  /// A transform with this stamp was taken by tf.
  void taken(double stamp);
  /// tf was cleared (a clock jump back, a restart): nothing taken yet.
  void clear() { newest_ = 0.0; }
  /// The newest stamp taken (0: none since the start or the last clear).
  double newest() const { return newest_; }
  double maxAheadS() const { return max_ahead_s_; }

 private:
  const double max_ahead_s_;
  double newest_ = 0.0;
  bool clock_trusted_ = false;  // a restart showed the clock right and a transform wrong
};

}  // namespace core
}  // namespace rbpf_slam
