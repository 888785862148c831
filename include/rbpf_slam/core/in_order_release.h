#pragma once
// Messages that leave a gate out of order, handed on in the order of their keys (stamps). The
// gate is tf2_ros::MessageFilter, which holds a message until tf covers its stamp: a later
// message that arrives when tf already covers it can leave before an earlier one still waiting,
// and the SLAM pipeline then refuses the earlier one ("stamp not after the last"). Here a
// message that left waits until every earlier one still in the gate has left or been dropped,
// unless that one cannot leave any more (MayStillLeave: for tf, the transform at its stamp is
// not there although a later one is, e.g. after a clock jump cleared the buffer; it would only
// die when the gate's queue overflows). At most max_held wait: beyond that the earliest goes
// on, and earlier keys the gate never answered for are forgotten.
// ROS-free, so that it is unit-tested without a roscore.

#include <algorithm>
#include <cstddef>
#include <functional>
#include <map>
#include <utility>
#include <vector>

namespace rbpf_slam {
namespace core {

template <typename Key, typename Value>
class InOrderRelease {
 public:
  /// Whether a message still in the gate can yet leave it (the gate's condition holds for it
  /// now, its release is on its way); one that cannot is not waited for.
  using MayStillLeave = std::function<bool(const Value&)>;

  explicit InOrderRelease(std::size_t max_held, MayStillLeave may_still_leave = nullptr)
      : max_held_(std::max<std::size_t>(max_held, 1)),
        may_still_leave_(std::move(may_still_leave)) {}

  /// A message went into the gate.
  void entered(const Key& key, const Value& value) { in_gate_.emplace(key, value); }

  /// The gate let this message out: the messages now due, in key order.
  std::vector<Value> left(const Key& key, Value value) {
    answered(key, value);
    held_.emplace(key, std::move(value));
    return due();
  }

  /// The gate dropped this message: the messages now due, in key order.
  std::vector<Value> dropped(const Key& key, const Value& value) {
    answered(key, value);
    return due();
  }

  /// Forgets everything (after a reset nothing from before it is handed on).
  void clear() {
    in_gate_.clear();
    held_.clear();
  }

  std::size_t inGate() const { return in_gate_.size(); }
  std::size_t held() const { return held_.size(); }

 private:
  /// The gate's entry of this message (not another with the same key) is answered for.
  void answered(const Key& key, const Value& value) {
    const auto range = in_gate_.equal_range(key);
    for (auto it = range.first; it != range.second; ++it) {
      if (it->second == value) {
        in_gate_.erase(it);
        return;
      }
    }
  }

  std::vector<Value> due() {
    std::vector<Value> out;
    while (!held_.empty()) {
      const Key first = held_.begin()->first;
      // Earlier messages that cannot leave any more are not waited for.
      while (!in_gate_.empty() && in_gate_.begin()->first < first && may_still_leave_ &&
             !may_still_leave_(in_gate_.begin()->second)) {
        in_gate_.erase(in_gate_.begin());
      }
      if (!in_gate_.empty() && in_gate_.begin()->first < first) {
        if (held_.size() <= max_held_) break;
        in_gate_.erase(in_gate_.begin(), in_gate_.lower_bound(first));  // never answered for
      }
      out.push_back(std::move(held_.begin()->second));
      held_.erase(held_.begin());
    }
    return out;
  }

  const std::size_t max_held_;
  const MayStillLeave may_still_leave_;
  std::multimap<Key, Value> in_gate_;  // the messages still in the gate
  std::multimap<Key, Value> held_;     // left the gate, waiting for an earlier one
};

}  // namespace core
}  // namespace rbpf_slam
