#pragma once
// What every node of the package does the same way with its inputs: warnings throttled per
// cause, and sensor topics that wait for tf in a bounded MessageFilter but drop (and name) a
// message whose frame tf does not know at all instead of letting it wait silently until the
// queue pushes it out.

#include <message_filters/subscriber.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_msgs/Header.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/message_filter.h>

#include <atomic>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/in_order_release.h"
#include "rbpf_slam/core/stamp_guard.h"
#include "rbpf_slam/ros/conversions.h"

namespace rbpf_slam {
namespace rosbridge {

// stripSlash, kFarStampS and farStampProblem are in conversions.h (the fuzzed conversions
// use them without this file's tf2_ros).


/// ROS_WARN at most once per period for each cause (a short key such as "no tf sonar_3").
class ThrottledWarnings {
 public:
  explicit ThrottledWarnings(std::string node_name, double period_s = 10.0)
      : node_name_(std::move(node_name)), period_s_(period_s) {}

  void warn(const std::string& cause, const std::string& message);

 private:
  const std::string node_name_;
  const double period_s_;
  std::map<std::string, ros::WallTime> last_;
};

/// What tf2_ros::TransformListener does (subscribe to /tf and /tf_static, feed the buffer from
/// a thread of its own, clear the buffer when the clock jumps back), with each transform
/// checked first (transformProblem: empty or equal frames, a stamp near 2^32 s, a non-finite
/// or unnormalised rotation; and a stamp more than a day after both the newest transform taken
/// and the clock, which would make tf2 drop every later real transform of that pair as old).
/// A repeat of a pair's newest stamp is skipped here, with a throttled warning giving the
/// count; what tf2 refuses itself (old data, a repeat of an older stamp) it logs, uncounted.
/// tf2_ros 0.7's listener catches only tf2's own exceptions: one /tf message stamped near
/// 2^32 s (a driver's -1) threw ros::Time's range error from its thread and ended the node. A
/// refused transform is dropped, counted and named in a warning (at most one per cause every
/// 10 s); the rest of its message is used.
class CheckedTransformListener {
 public:
  CheckedTransformListener(tf2::BufferCore& buffer, const ros::NodeHandle& nh,
                           std::string node_name);
  ~CheckedTransformListener();
  CheckedTransformListener(const CheckedTransformListener&) = delete;
  CheckedTransformListener& operator=(const CheckedTransformListener&) = delete;

  /// Stops the thread and the subscriptions (a node's destructor, before its tf queues go).
  void stop();
  /// Clears the buffer and what the listener remembers of the stamps taken (a node's reset):
  /// a transform repeating a stamp taken before the clear is taken again.
  void clear();
  /// A /tf stamp further than this after both the newest transform taken and the clock is
  /// refused (s); a newest transform this far ahead of the clock, with later ones agreeing with
  /// the clock, was the outlier (core::StampGuard).
  static constexpr double kMaxAheadS = 86400.0;
  /// Times the buffer was cleared because the newest transform taken was far ahead of the clock.
  long restarts() const { return restarts_.load(); }

  /// Transforms refused since the last call (for a diagnostics period).
  long takeRefused() {
    const long total = refused_.load();
    const long fresh = total - taken_;
    taken_ = total;
    return fresh;
  }

 private:
  void handle(const tf2_msgs::TFMessage& msg, const std::string& authority, bool is_static);

  tf2::BufferCore& buffer_;
  ros::CallbackQueue queue_;
  ros::NodeHandle nh_;
  ros::Subscriber tf_subscriber_, static_subscriber_;
  ros::AsyncSpinner spinner_;
  const std::string node_name_;
  std::mutex mutex_;  // last_update_, guard_, warnings_ and repeated_ (handle's state)
  ros::Time last_update_;
  core::StampGuard guard_{kMaxAheadS};  // the non-static stamps taken, against far-off ones
  ThrottledWarnings warnings_;
  std::map<std::string, long> repeated_;  // per child frame (no leading slash): repeats skipped
  std::atomic<long> refused_{0};
  std::atomic<long> restarts_{0};
  long taken_ = 0;  // refused_ as of the last takeRefused (the caller's thread)
};

/// False, with tf's explanation in *error, when tf knows base_frame but has no path from it to
/// frame. True for an empty frame (the MessageFilter reports that) and while tf has no
/// base_frame yet (start-up: everything waits in the bounded queue).
bool frameInTf(const tf2_ros::Buffer& tf, const std::string& base_frame, const std::string& frame,
               std::string* error);

/// Sonar transducer poses in the base frame from tf frames PREFIX0, PREFIX1, ... (up to 64,
/// until one is missing); empty when tf has no PREFIX0. For a sonar ring given as one cloud.
std::vector<core::Pose2> lookupTransducers(const tf2::BufferCore& tf, const std::string& base,
                                           const std::string& prefix, const ros::Time& stamp);

/// A subscription whose messages reach on_message only once tf can transform their stamp into
/// target_frame (tf2_ros::MessageFilter, bounded queue), in the order of their stamps
/// (core::InOrderRelease: the filter alone let a later message overtake one still waiting for
/// tf, and the pipeline refused the earlier one, 4 of an MRCLAM bag's 1012 frames at rate 10).
/// A message the filter has not let out although tf covers it is handed on without it, when a
/// later one leaves or at the next sweep (every kSweepPeriodS while messages wait): tf2_ros 0.7
/// can lose the filter's answer (core/in_order_release.h), and the message would wait until the
/// filter's queue overflows (for good if later messages leave at once).
/// Messages in a frame not connected to base_frame go to on_unknown_frame at once; messages the
/// filter gives up on before they were handed on go to on_failure.
template <typename Message>
class TfGatedSubscriber {
 public:
  using Ptr = boost::shared_ptr<const Message>;
  struct Handlers {
    std::function<void(const Ptr&)> on_message;
    /// A stamp tf2 cannot handle (farStampProblem: near 2^32 s, a driver's -1): its time
    /// arithmetic throws, which used to end the node from ros::spin. The message is dropped.
    std::function<void(const Ptr&, const std::string& why)> on_bad_stamp;
    std::function<void(const Ptr&, tf2_ros::FilterFailureReason)> on_failure;
    std::function<void(const Ptr&, const std::string& tf_error)> on_unknown_frame;
    /// Stamped before the earliest transform tf holds on its way to the target frame, within
    /// tf's cache length of the latest (e.g. a reading published before the first odometry):
    /// it can never leave (dropBeforeTf). Without this handler, and for messages that fell out
    /// of tf's cache, on_failure with OutTheBack.
    std::function<void(const Ptr&)> on_before_tf;
  };

  TfGatedSubscriber(ros::NodeHandle nh, const std::string& topic, uint32_t queue_size,
                    tf2_ros::Buffer* tf, std::string base_frame, const std::string& target_frame,
                    Handlers handlers)
      : tf_(tf),
        base_frame_(std::move(base_frame)),
        target_frame_(stripSlash(target_frame)),
        handlers_(std::move(handlers)),
        filter_(*tf, target_frame, queue_size, nh),
        order_(queue_size, [this, target = stripSlash(target_frame)](const Ptr& msg) {
          // An empty frame is the filter's to refuse (tf2 would log an error for it here).
          const std::string frame = stripSlash(msg->header.frame_id);
          try {
            return !frame.empty() && tf_->canTransform(target, frame, msg->header.stamp);
          } catch (const std::exception&) {  // tf2's time arithmetic: the filter's to answer
            return false;
          }
        }) {
    // An empty topic: no subscription, the owner feeds messages with add() (a topic whose
    // messages come in another type first, e.g. PointCloud2 converted to PointCloud).
    if (!topic.empty()) {
      subscriber_.subscribe(nh, topic, queue_size);
      subscriber_.registerCallback(boost::function<void(const Ptr&)>([this](const Ptr& msg) {
        if (received_++ == 0) first_received_ = ros::WallTime::now();
        add(msg);
      }));
    }
    filter_.registerCallback(boost::function<void(const Ptr&)>([this](const Ptr& msg) {
      answered(msg);
      deliver(order_.left(msg->header.stamp, msg), clears_);
    }));
    filter_.registerFailureCallback([this](const Ptr& msg, tf2_ros::FilterFailureReason reason) {
      answered(msg);
      bool handed_on = false;  // then the filter gives up on a message already processed
      std::vector<Ptr> due = order_.dropped(msg->header.stamp, msg, &handed_on);
      const unsigned long clears = clears_;  // on_failure may reset the input
      if (!handed_on && handlers_.on_failure) handlers_.on_failure(msg, reason);
      deliver(std::move(due), clears);
    });
    sweep_timer_ = nh.createWallTimer(ros::WallDuration(kSweepPeriodS),
                                      [this](const ros::WallTimerEvent&) {
                                        if (order_.inGate() > 0) deliver(order_.sweep(), clears_);
                                        if (!pending_.empty()) dropBeforeTf();
                                      });
  }
  TfGatedSubscriber(const TfGatedSubscriber&) = delete;
  TfGatedSubscriber& operator=(const TfGatedSubscriber&) = delete;

  /// s between two sweeps for messages the filter has not let out although tf covers them.
  static constexpr double kSweepPeriodS = 0.1;

  /// A message into the tf gate, as if it had arrived on the topic.
  void add(const Ptr& msg) {
    std::string error = farStampProblem(msg->header.stamp);
    if (!error.empty()) {
      if (handlers_.on_bad_stamp) handlers_.on_bad_stamp(msg, error);
      return;
    }
    if (frameInTf(*tf_, base_frame_, msg->header.frame_id, &error)) {
      order_.entered(msg->header.stamp, msg);  // before add(): the filter may answer at once
      pending_.emplace(msg->header.stamp, msg);
      intoFilter(msg);
    } else if (handlers_.on_unknown_frame) {
      handlers_.on_unknown_frame(msg, error);
    }
  }
  /// Empties the tf queue (after a reset: nothing queued before it is processed after it).
  void clear() {
    filter_.clear();
    order_.clear();
    pending_.clear();
    ++clears_;
  }
  std::string topic() const { return subscriber_.getTopic(); }
  /// Messages that arrived on the topic (whatever became of them), and when the first did.
  unsigned long received() const { return received_; }
  ros::WallTime firstReceived() const { return first_received_; }

 private:
  /// Hands on the messages due unless the input was reset since `clears` was read (by a
  /// handler, here or before): those are from before the reset.
  void deliver(std::vector<Ptr> due, unsigned long clears) {
    for (const Ptr& msg : due) {
      if (clears_ != clears) return;  // a handler reset the input: the rest is from before it
      handlers_.on_message(msg);
    }
  }

  /// Gives the filter a message already in order_ and pending_ (it may answer at once).
  void intoFilter(const Ptr& msg) {
    try {
      filter_.add(msg);
    } catch (const std::exception& e) {  // tf2's time arithmetic, whatever the stamp
      answered(msg);
      bool handed_on = false;
      std::vector<Ptr> due = order_.dropped(msg->header.stamp, msg, &handed_on);
      const unsigned long clears = clears_;  // on_bad_stamp may reset the input
      if (!handed_on && handlers_.on_bad_stamp) handlers_.on_bad_stamp(msg, e.what());
      deliver(std::move(due), clears);
    }
  }

  /// The filter answered for this message (let it out or gave up on it).
  void answered(const Ptr& msg) {
    const auto range = pending_.equal_range(msg->header.stamp);
    for (auto it = range.first; it != range.second; ++it) {
      if (it->second == msg) {
        pending_.erase(it);
        return;
      }
    }
  }

  /// A message the filter holds unanswered that is stamped before the earliest transform tf
  /// holds for it (tf2: "extrapolation into the past"; e.g. readings a driver publishes before
  /// its first odometry) can never leave: tf2 gives up on it only once its cache has moved a
  /// whole cache length past it (30 s), and tf2_ros 0.7 then also fails the messages waiting at
  /// that moment. Such messages are reported now (on_before_tf); the filter cannot drop one
  /// message, so it is emptied and the others are given to it again, in stamp order.
  void dropBeforeTf() {
    std::vector<std::pair<Ptr, bool>> waiting;  // and whether it is before tf's history
    std::vector<Ptr> keep;                      // may still leave
    for (const auto& entry : pending_) {
      const Ptr& msg = entry.second;
      std::string error;
      const std::string frame = stripSlash(msg->header.frame_id);
      try {
        if (frame.empty() || tf_->canTransform(target_frame_, frame, msg->header.stamp, &error) ||
            error.find("into the past") == std::string::npos) {
          keep.push_back(msg);  // the filter's to answer for
          continue;
        }
      } catch (const std::exception&) {  // tf2's time arithmetic (a stamp 2^31 s off): the
        keep.push_back(msg);             // filter's to answer for, as before
        continue;
      }
      // Before tf's history (its data began later: start-up, a mount first sent late), or fell
      // out of its cache (older than the clock less tf's cache length: a node that fell behind).
      const double now = ros::Time::now().toSec();
      const bool before_history =
          now <= 0.0 || msg->header.stamp.toSec() >= now - tf_->getCacheLength().toSec();
      waiting.emplace_back(msg, before_history);
    }
    if (waiting.empty()) return;
    filter_.clear();  // no failure callbacks; its tf2 requests go too
    pending_.clear();
    for (const Ptr& msg : keep) pending_.emplace(msg->header.stamp, msg);
    const unsigned long clears = clears_;
    for (const auto& [msg, before_history] : waiting) {
      bool handed_on = false;
      std::vector<Ptr> due = order_.dropped(msg->header.stamp, msg, &handed_on);
      if (!handed_on) {
        if (before_history && handlers_.on_before_tf) {
          handlers_.on_before_tf(msg);
        } else if (handlers_.on_failure) {
          handlers_.on_failure(msg, tf2_ros::filter_failure_reasons::OutTheBack);
        }
      }
      if (clears_ != clears) return;  // a handler reset the input
      deliver(std::move(due), clears);
    }
    for (const Ptr& msg : keep) {  // back into the filter (still in order_ and pending_)
      if (clears_ != clears) return;
      intoFilter(msg);
    }
  }

  tf2_ros::Buffer* tf_;
  const std::string base_frame_;
  const std::string target_frame_;
  const Handlers handlers_;
  std::multimap<ros::Time, Ptr> pending_;  // in the filter, not answered for yet
  unsigned long received_ = 0;
  ros::WallTime first_received_;
  message_filters::Subscriber<Message> subscriber_;
  tf2_ros::MessageFilter<Message> filter_;
  core::InOrderRelease<ros::Time, Ptr> order_;
  ros::WallTimer sweep_timer_;
  unsigned long clears_ = 0;
};

}  // namespace rosbridge
}  // namespace rbpf_slam
