#pragma once
// Messages that leave a gate out of order, handed on in the order of their keys (stamps). The
// gate is tf2_ros::MessageFilter, which holds a message until tf covers its stamp: a later
// message that arrives when tf already covers it can leave before an earlier one still waiting,
// and the SLAM pipeline then refuses the earlier one ("stamp not after the last"). Here a
// message that left waits until every earlier one still in the gate has left or been dropped.
//
// With a CanLeaveNow test (for tf: the transform at the message's stamp is there now), nothing
// waits on the gate's own answer. An earlier message that could leave now is handed on at once,
// in order, and the gate's answer for it, when it comes, is ignored. The filter can lose that
// answer: tf2_ros 0.7's MessageFilter registers a message's transform request before queueing
// the message, and a transform arriving on tf's thread in between fires the request while the
// message is not yet queued, so the message is never let out until the filter's queue overflows
// (never, if later messages leave at once); tf2's own request can also miss a transform set
// between its check and its registration, and wait for the next one. One that cannot leave now,
// although a later one could, never will (e.g. after a clock jump cleared the buffer) and is
// forgotten: this holds for messages whose frames hang on the same moving transform (a sensor's
// frames, static on the base), which is how the nodes use it. sweep() does the same without a
// later message, for the last ones of a stream.
// Without the test, at most max_held wait: beyond that the earliest goes on, and earlier keys the
// gate never answered for are forgotten.
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
  /// Whether a message still in the gate could leave it now (the gate's condition holds for
  /// it); it is then handed on without waiting for the gate.
  using CanLeaveNow = std::function<bool(const Value&)>;

  explicit InOrderRelease(std::size_t max_held, CanLeaveNow can_leave_now = nullptr)
      : max_held_(std::max<std::size_t>(max_held, 1)), can_leave_now_(std::move(can_leave_now)) {}

  /// A message went into the gate.
  void entered(const Key& key, const Value& value) { in_gate_.emplace(key, value); }

  /// The gate let this message out: the messages now due, in key order (without this one if it
  /// was handed on already).
  std::vector<Value> left(const Key& key, Value value) {
    if (!takeHandedOn(key, value)) {
      answered(key, value);
      held_.emplace(key, std::move(value));
    }
    return due();
  }

  /// The gate dropped this message: the messages now due, in key order. *handed_on (optional)
  /// tells whether it had been handed on before the gate gave up on it.
  std::vector<Value> dropped(const Key& key, const Value& value, bool* handed_on = nullptr) {
    const bool before = takeHandedOn(key, value);
    if (!before) answered(key, value);
    if (handed_on) *handed_on = before;
    return due();
  }

  /// Hands on, in key order, every message in the gate that can leave now, and forgets those
  /// before the last of them that cannot (they never will). Nothing without CanLeaveNow.
  std::vector<Value> sweep() {
    if (!can_leave_now_) return {};
    // Latest first: tf may grow between two tests, and an earlier message must not be found
    // unable to leave after a later one was found able (it would be forgotten, then let out
    // after the later one).
    std::vector<bool> can(in_gate_.size());
    std::size_t i = can.size();
    for (auto it = in_gate_.rbegin(); it != in_gate_.rend(); ++it) {
      can[--i] = can_leave_now_(it->second);
    }
    const auto last = std::find(can.rbegin(), can.rend(), true);
    if (last == can.rend()) return {};
    const std::size_t through = static_cast<std::size_t>(can.rend() - last);  // entries to take
    auto it = in_gate_.begin();
    for (std::size_t k = 0; k < through; ++k) {
      if (can[k]) handOnEarly(it->first, it->second);
      it = in_gate_.erase(it);
    }
    return due();
  }

  /// Forgets everything (after a reset nothing from before it is handed on).
  void clear() {
    in_gate_.clear();
    held_.clear();
    handed_on_.clear();
  }

  std::size_t inGate() const { return in_gate_.size(); }
  /// The messages still in the gate, in key order.
  std::vector<Value> inGateValues() const {
    std::vector<Value> out;
    for (const auto& entry : in_gate_) out.push_back(entry.second);
    return out;
  }
  std::size_t held() const { return held_.size(); }

 private:
  /// The gate's entry of this message (not another with the same key) is answered for.
  void answered(const Key& key, const Value& value) { eraseOne(&in_gate_, key, value); }

  /// Whether the message was handed on before the gate answered (that entry is then taken).
  bool takeHandedOn(const Key& key, const Value& value) {
    return eraseOne(&handed_on_, key, value);
  }

  /// The message goes on without the gate's answer; the answer is ignored when it comes. The
  /// gate may never answer (the lost request): at most 2 max_held such entries are kept, the
  /// earliest stamp forgotten first; should the gate answer for one forgotten, the message is
  /// handed on again (the pipeline refuses it as not after the last).
  void handOnEarly(const Key& key, const Value& value) {
    held_.emplace(key, value);
    handed_on_.emplace(key, value);
    while (handed_on_.size() > 2 * max_held_) handed_on_.erase(handed_on_.begin());
  }

  static bool eraseOne(std::multimap<Key, Value>* entries, const Key& key, const Value& value) {
    const auto range = entries->equal_range(key);
    for (auto it = range.first; it != range.second; ++it) {
      if (it->second == value) {
        entries->erase(it);
        return true;
      }
    }
    return false;
  }

  std::vector<Value> due() {
    std::vector<Value> out;
    while (!held_.empty()) {
      const Key first = held_.begin()->first;
      if (can_leave_now_) {
        // Earlier messages still in the gate go first if they can leave now; the others never
        // will (a later one could) and are forgotten.
        while (!in_gate_.empty() && in_gate_.begin()->first < first) {
          const auto earliest = in_gate_.begin();
          if (can_leave_now_(earliest->second)) handOnEarly(earliest->first, earliest->second);
          in_gate_.erase(earliest);
        }
        if (held_.begin()->first < first) continue;  // one was handed on early: it goes first
      } else if (!in_gate_.empty() && in_gate_.begin()->first < first) {
        if (held_.size() <= max_held_) break;
        in_gate_.erase(in_gate_.begin(), in_gate_.lower_bound(first));  // never answered for
      }
      out.push_back(std::move(held_.begin()->second));
      held_.erase(held_.begin());
    }
    return out;
  }

  const std::size_t max_held_;
  const CanLeaveNow can_leave_now_;
  std::multimap<Key, Value> in_gate_;    // the messages still in the gate
  std::multimap<Key, Value> held_;       // left the gate, waiting for an earlier one
  std::multimap<Key, Value> handed_on_;  // handed on before the gate answered for them
};

}  // namespace core
}  // namespace rbpf_slam
