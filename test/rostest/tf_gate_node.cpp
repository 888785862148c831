// rosbridge::TfGatedSubscriber, the glue between tf2's MessageFilter and core::InOrderRelease
// (test_in_order_release tests the ordering alone): messages waiting for tf are handed on in
// the order of their stamps, whatever order they came in; clear() drops what waits; a frame tf
// does not connect to the base goes to on_unknown_frame at once. Messages come through add()
// (no topic); the transforms are set on the buffer by hand. Needs a roscore (tf_gate.test):
// the filter's answers go through the node's callback queue.

#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>

#include <cmath>
#include <string>
#include <vector>

#include "rbpf_slam/ros/node_support.h"

namespace rbpf_slam {
namespace {

using Scan = sensor_msgs::LaserScan;
using Gate = rosbridge::TfGatedSubscriber<Scan>;

geometry_msgs::TransformStamped odomToBase(double stamp) {
  geometry_msgs::TransformStamped t;
  t.header.frame_id = "odom";
  t.header.stamp = ros::Time(stamp);
  t.child_frame_id = "base_link";
  t.transform.rotation.w = 1.0;
  t.transform.translation.x = 0.1 * stamp;
  return t;
}

Gate::Ptr scan(double stamp, const std::string& frame = "base_link") {
  boost::shared_ptr<Scan> msg(new Scan);
  msg->header.stamp = ros::Time(stamp);
  msg->header.frame_id = frame;
  return msg;
}

/// Runs the node's callbacks (the filter's answers) for `seconds`, or until `done` holds.
template <typename Done>
void spinUntil(double seconds, Done done) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::WallTime::now() < end && !done()) {
    ros::spinOnce();
    ros::WallDuration(0.01).sleep();
  }
  ros::spinOnce();  // whatever else is queued by then
}

struct Recorder {
  std::vector<double> delivered, unknown, failed, before_tf;
  Gate::Handlers handlers() {
    Gate::Handlers h;
    h.on_message = [this](const Gate::Ptr& m) { delivered.push_back(m->header.stamp.toSec()); };
    h.on_failure = [this](const Gate::Ptr& m, tf2_ros::FilterFailureReason) {
      failed.push_back(m->header.stamp.toSec());
    };
    h.on_unknown_frame = [this](const Gate::Ptr& m, const std::string&) {
      unknown.push_back(m->header.stamp.toSec());
    };
    h.on_before_tf = [this](const Gate::Ptr& m) { before_tf.push_back(m->header.stamp.toSec()); };
    return h;
  }
};

TEST(TfGatedSubscriber, MessagesWaitingForTfLeaveInStampOrder) {
  ros::NodeHandle nh;
  tf2_ros::Buffer tf;
  tf.setTransform(odomToBase(100.0), "test", false);  // base_link known, stamps 101+ wait
  Recorder r;
  Gate gate(nh, "", 10, &tf, "base_link", "odom", r.handlers());
  for (double stamp : {103.0, 101.0, 102.0}) gate.add(scan(stamp));
  spinUntil(0.3, [] { return false; });
  EXPECT_TRUE(r.delivered.empty()) << "handed on before tf had the stamps";
  tf.setTransform(odomToBase(104.0), "test", false);  // all three can be transformed now
  spinUntil(5.0, [&r] { return r.delivered.size() >= 3; });
  // The filter answers in its queue's order (103 first); without the in-order release, 103
  // would be handed on first and the pipeline would refuse 101 and 102 as older.
  EXPECT_EQ(r.delivered, (std::vector<double>{101.0, 102.0, 103.0}));
  EXPECT_TRUE(r.failed.empty());
  EXPECT_TRUE(r.unknown.empty());
}

TEST(TfGatedSubscriber, ClearDropsWhatWaitsAndUnknownFramesAreNamedAtOnce) {
  ros::NodeHandle nh;
  tf2_ros::Buffer tf;
  tf.setTransform(odomToBase(100.0), "test", false);
  Recorder r;
  Gate gate(nh, "", 10, &tf, "base_link", "odom", r.handlers());
  gate.add(scan(101.0));
  gate.add(scan(102.0, "no_such_frame"));  // tf knows base_link but not this frame
  EXPECT_EQ(r.unknown, (std::vector<double>{102.0})) << "an unknown frame must not wait";
  gate.clear();  // e.g. after the clock jumped back
  gate.add(scan(103.0));
  tf.setTransform(odomToBase(104.0), "test", false);
  spinUntil(5.0, [&r] { return !r.delivered.empty(); });
  spinUntil(0.2, [] { return false; });  // a message from before clear() would come by now
  EXPECT_EQ(r.delivered, (std::vector<double>{103.0})) << "a message from before clear() left";
  EXPECT_TRUE(r.failed.empty());
}

/// odom -> base_link at t0 and t0 + 1 s, t0 the clock's last whole second (within tf's cache of
/// the clock, so that older stamps are before tf's history, not out of its cache); returns t0.
double twoTransformsNow(tf2_ros::Buffer* tf) {
  const double t0 = std::floor(ros::Time::now().toSec());
  tf->setTransform(odomToBase(t0), "test", false);
  tf->setTransform(odomToBase(t0 + 1.0), "test", false);
  return t0;
}

// A reading stamped before tf's first odometry (a driver that publishes its sensors first) can
// never be transformed: it is dropped at the next sweep (on_before_tf), even while a newer
// reading waits for tf, and the newer one still leaves once tf has its stamp. Before, the newer
// one postponed the drop, and at high rates one always waits: tf2 gave up 30 s later.
TEST(TfGatedSubscriber, AReadingBeforeTfIsDroppedWhileANewerOneWaits) {
  ros::NodeHandle nh;
  tf2_ros::Buffer tf;
  const double t0 = twoTransformsNow(&tf);
  Recorder r;
  Gate gate(nh, "", 10, &tf, "base_link", "odom", r.handlers());
  gate.add(scan(t0 - 0.5));  // before tf's history
  gate.add(scan(t0 + 2.0));  // waits for tf
  gate.add(scan(t0 + 0.5));  // leaves at once
  spinUntil(5.0 * Gate::kSweepPeriodS, [&r] { return !r.before_tf.empty(); });
  EXPECT_EQ(r.before_tf, (std::vector<double>{t0 - 0.5}))
      << "not dropped within five sweeps while a newer reading waits";
  EXPECT_EQ(r.delivered, (std::vector<double>{t0 + 0.5}));
  tf.setTransform(odomToBase(t0 + 3.0), "test", false);
  spinUntil(5.0, [&r] { return r.delivered.size() >= 2; });
  EXPECT_EQ(r.delivered, (std::vector<double>{t0 + 0.5, t0 + 2.0}))
      << "the waiting reading was lost when the filter was emptied";
  EXPECT_TRUE(r.failed.empty());
}

// The readings kept when the filter is emptied are in it again: in a queue of 2, two later
// readings push the oldest kept one out, which the filter reports as a failure. Had it not
// been given back, nothing would ever answer for it.
TEST(TfGatedSubscriber, TheReadingsKeptAreGivenBackToTheFilter) {
  ros::NodeHandle nh;
  tf2_ros::Buffer tf;
  const double t0 = twoTransformsNow(&tf);
  Recorder r;
  Gate gate(nh, "", 2, &tf, "base_link", "odom", r.handlers());
  gate.add(scan(t0 - 0.5));  // before tf's history
  gate.add(scan(t0 + 2.0));  // waits for tf
  spinUntil(5.0 * Gate::kSweepPeriodS, [&r] { return !r.before_tf.empty(); });
  ASSERT_EQ(r.before_tf, (std::vector<double>{t0 - 0.5}));
  gate.add(scan(t0 + 2.1));
  gate.add(scan(t0 + 2.2));
  spinUntil(2.0, [&r] { return !r.failed.empty(); });
  EXPECT_EQ(r.failed, (std::vector<double>{t0 + 2.0}));
}

// rosbridge::CheckedTransformListener with a first transform stamped two days ahead (a
// driver's garbage at start-up): tf2 would refuse every real transform of that pair as older
// than it, and nothing would move again. The first real one, which agrees with the clock, makes
// the listener clear its buffer and take it (core::StampGuard; test_stamp_guard has the rules).
TEST(CheckedTransformListener, AFirstTransformFarAheadDoesNotBlockTheRealOnes) {
  ros::NodeHandle nh;
  tf2_ros::Buffer tf;
  rosbridge::CheckedTransformListener listener(tf, nh, "tf_gate_test");
  ros::Publisher publisher = nh.advertise<tf2_msgs::TFMessage>("/tf", 10);
  spinUntil(5.0, [&publisher] { return publisher.getNumSubscribers() > 0; });
  ASSERT_GT(publisher.getNumSubscribers(), 0u);
  const double now = ros::Time::now().toSec();
  auto send = [&publisher](double stamp) {
    tf2_msgs::TFMessage msg;
    msg.transforms.push_back(odomToBase(stamp));
    publisher.publish(msg);
  };
  send(now + 2 * 86400.0);
  spinUntil(5.0, [&tf, now] {
    return tf.canTransform("odom", "base_link", ros::Time(now + 2 * 86400.0));
  });
  for (int i = 1; i <= 3; ++i) send(now + 0.1 * i);
  spinUntil(5.0, [&tf, now] { return tf.canTransform("odom", "base_link", ros::Time(now + 0.2)); });
  EXPECT_TRUE(tf.canTransform("odom", "base_link", ros::Time(now + 0.2)))
      << "the real transforms were refused behind the far one";
  EXPECT_EQ(listener.restarts(), 1);
  EXPECT_EQ(listener.takeRefused(), 0);
  send(now + 3 * 86400.0);  // now the clock is the reference: refused, counted
  spinUntil(5.0, [&listener] { return listener.takeRefused() > 0; });
  EXPECT_FALSE(tf.canTransform("odom", "base_link", ros::Time(now + 3 * 86400.0)));
  EXPECT_EQ(listener.restarts(), 1);
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "tf_gate_test");
  ros::NodeHandle keep_alive;  // the node stays up between the tests' own handles
  return RUN_ALL_TESTS();
}
