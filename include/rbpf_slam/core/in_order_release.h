#pragma once
// Messages that leave a gate out of order, handed on in the order of their keys (stamps). The
// gate is tf2_ros::MessageFilter, which holds a message until tf covers its stamp: a later
// message that arrives when tf already covers it can leave before an earlier one still waiting,
// and the SLAM pipeline then refuses the earlier one ("stamp not after the last"). Here a
// message that left waits until every earlier one still in the gate has left or been dropped.
// At most max_held wait: beyond that the earliest goes on, and earlier keys the gate never
// answered for are forgotten (a gate that loses a message silently cannot stall the stream).
// ROS-free, so that it is unit-tested without a roscore.

#include <algorithm>
#include <cstddef>
#include <map>
#include <set>
#include <utility>
#include <vector>

namespace rbpf_slam {
namespace core {

template <typename Key, typename Value>
class InOrderRelease {
 public:
  explicit InOrderRelease(std::size_t max_held) : max_held_(std::max<std::size_t>(max_held, 1)) {}

  /// A message with this key went into the gate.
  void entered(const Key& key) { in_gate_.insert(key); }

  /// The gate let the message with this key out: the messages now due, in key order.
  std::vector<Value> left(const Key& key, Value value) {
    answered(key);
    held_.emplace(key, std::move(value));
    return due();
  }

  /// The gate dropped the message with this key: the messages now due, in key order.
  std::vector<Value> dropped(const Key& key) {
    answered(key);
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
  void answered(const Key& key) {
    const auto it = in_gate_.find(key);
    if (it != in_gate_.end()) in_gate_.erase(it);
  }

  std::vector<Value> due() {
    std::vector<Value> out;
    while (!held_.empty()) {
      const Key first = held_.begin()->first;
      if (!in_gate_.empty() && *in_gate_.begin() < first) {
        if (held_.size() <= max_held_) break;
        in_gate_.erase(in_gate_.begin(), in_gate_.lower_bound(first));  // never answered for
      }
      out.push_back(std::move(held_.begin()->second));
      held_.erase(held_.begin());
    }
    return out;
  }

  const std::size_t max_held_;
  std::multiset<Key> in_gate_;        // keys of the messages still in the gate
  std::multimap<Key, Value> held_;    // left the gate, waiting for an earlier one
};

}  // namespace core
}  // namespace rbpf_slam
