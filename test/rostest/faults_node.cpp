// Fault injection against a running rbpf_slam_node (faults.test). This node is the robot: it
// owns /clock, broadcasts odom -> base_link and base_link -> laser, and publishes scans of a
// rectangular room computed exactly. Between stretches of good data it injects one fault
// class at a time and checks the named outcome: the message is dropped with its cause counted
// in /diagnostics, or processed without harm; afterwards the node keeps updating. Throughout,
// nothing non-finite may be published and map -> odom never repeats a stamp within one run
// of the clock. Then the clock jumps back (a bag loop): the node must clear its map, count
// a reset and map again. Last, 35 s without scans while odometry flows must not count as an
// odometry gap in /diagnostics, 35 s without odometry must.

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <gtest/gtest.h>
#include <rbpf_slam/FeatureArray.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/LaserScan.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <utility>

#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/ros/conversions.h"
#include "fault_test_support.h"

namespace rbpf_slam {
namespace {

using fault_test::Observer;

constexpr double kHalfX = 5.0, kHalfY = 4.0;  // the room: [-5, 5] x [-4, 4] m
constexpr int kBeams = 181;
constexpr double kStep = 0.5;  // s of simulated time per scan

/// The robot: drives a circle of radius 1.5 m at 0.3 m/s in the room, with exact odometry.
class Robot {
 public:
  Robot() {
    ros::NodeHandle nh;
    clock_pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
    scan_pub_ = nh.advertise<sensor_msgs::LaserScan>("/scan", 10);
    features_pub_ = nh.advertise<FeatureArray>("/features", 10);
    tf_pub_ = nh.advertise<tf2_msgs::TFMessage>("/tf", 10);
    geometry_msgs::TransformStamped laser =
        rosbridge::toTransformStamped(core::Pose2(0.1, 0.0, 0.0), "base_link", "laser", ros::Time(0.0));
    static_broadcaster_.sendTransform(laser);
  }
  double time() const { return t_; }
  core::Pose2 truth(double t) const {
    const double w = 0.3 / 1.5;  // rad/s
    return core::Pose2(1.5 * std::sin(w * t), 1.5 - 1.5 * std::cos(w * t), core::wrapAngle(w * t));
  }
  /// Advances the clock one step and publishes odometry (unless tf is off) at the new time.
  void tick(bool with_tf = true) {
    t_ += kStep;
    publishClock(t_);
    if (with_tf) broadcaster_.sendTransform(odometry());
    ros::WallDuration(0.03).sleep();
  }
  /// odom -> base_link at the current time.
  geometry_msgs::TransformStamped odometry() const {
    core::Pose2 odom = truth(t_);
    odom.x() += odom_offset_x_;
    return rosbridge::toTransformStamped(odom, "odom", "base_link", ros::Time(t_));
  }
  /// A correct scan at the current time.
  sensor_msgs::LaserScan scan() const {
    sensor_msgs::LaserScan msg;
    msg.header.stamp = ros::Time(t_);
    msg.header.frame_id = "laser";
    msg.angle_min = -M_PI / 2;
    msg.angle_max = M_PI / 2;
    msg.angle_increment = M_PI / (kBeams - 1);
    msg.range_min = 0.05;
    msg.range_max = 30.0;
    const core::Pose2 base = truth(t_);
    const core::Pose2 laser = core::compose(base, core::Pose2(0.1, 0.0, 0.0));
    for (int i = 0; i < kBeams; ++i) {
      msg.ranges.push_back(static_cast<float>(
          fault_test::rangeToWall(laser.x(), laser.y(),
                                laser.z() + msg.angle_min + i * msg.angle_increment, kHalfX, kHalfY)));
    }
    return msg;
  }
  void publish(const sensor_msgs::LaserScan& msg) {
    scan_pub_.publish(msg);
    ros::WallDuration(0.05).sleep();
  }
  void publish(const FeatureArray& msg) {
    features_pub_.publish(msg);
    ros::WallDuration(0.05).sleep();
  }
  /// n ordinary steps.
  void drive(int n) {
    for (int i = 0; i < n; ++i) {
      tick();
      publish(scan());
    }
  }
  /// One /tf message, as another node on the robot would send it.
  void publishTf(const tf2_msgs::TFMessage& msg) {
    tf_pub_.publish(msg);
    ros::WallDuration(0.05).sleep();
  }
  void jumpOdometry(double dx) { odom_offset_x_ += dx; }
  /// The clock goes back (rosbag play -l): the route starts over at t.
  void restartClockAt(double t) {
    t_ = t;
    odom_offset_x_ = 0.0;
    publishClock(t_);
    ros::WallDuration(0.1).sleep();
  }
  bool subscribed() const {
    return scan_pub_.getNumSubscribers() > 0 && clock_pub_.getNumSubscribers() > 0 &&
           features_pub_.getNumSubscribers() > 0;
  }

 private:
  void publishClock(double t) {
    rosgraph_msgs::Clock clock;
    clock.clock = ros::Time(t);
    clock_pub_.publish(clock);
  }
  ros::Publisher clock_pub_, scan_pub_, features_pub_, tf_pub_;
  tf2_ros::TransformBroadcaster broadcaster_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
  double t_ = 1.0;
  double odom_offset_x_ = 0.0;
};

class FaultsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    observer_ = new Observer();
    robot_ = new Robot();
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
    while (!robot_->subscribed() && ros::WallTime::now() < deadline) {
      ros::WallDuration(0.1).sleep();
    }
  }
  /// Waits for a /diagnostics report produced after everything sent so far was handled. A node
  /// that reports nothing for 15 s fails the test: the counters read next would be stale, and
  /// a "nothing changed" check would pass without testing anything.
  static void settle() {
    ros::WallDuration(0.3).sleep();
    const ros::WallTime since = ros::WallTime::now();
    const ros::WallTime deadline = since + ros::WallDuration(15.0);
    while (observer_->lastDiagnostics() <= since && ros::WallTime::now() < deadline) {
      ros::WallDuration(0.05).sleep();
    }
    if (observer_->lastDiagnostics() <= since) ADD_FAILURE() << "no /diagnostics for 15 s";
  }
  /// Waits (up to 20 s of wall time, for a loaded machine) until the node has published a
  /// pose stamped at the robot's current time; true if it did.
  static bool caughtUp() {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(20.0);
    while (ros::WallTime::now() < deadline) {
      if (std::fabs(observer_->lastPoseStamp() - robot_->time()) < 1e-6) return true;
      ros::WallDuration(0.05).sleep();
    }
    return false;
  }
  /// Good data after a fault: the node updates again (a pose stamped at the newest time).
  static void expectRecovers(const std::string& after) {
    robot_->drive(6);
    EXPECT_TRUE(caughtUp()) << "no update on good data after " << after << " (last pose at "
                            << observer_->lastPoseStamp() << ", now " << robot_->time() << ")";
    settle();
  }
  static Observer* observer_;
  static Robot* robot_;
};
Observer* FaultsTest::observer_ = nullptr;
Robot* FaultsTest::robot_ = nullptr;

// The tests run in declaration order on one node (gtest keeps the order within a suite).

TEST_F(FaultsTest, A_MapsTheRoomFromGoodData) {
  ASSERT_TRUE(robot_->subscribed()) << "rbpf_slam_node did not subscribe to /scan and /clock";
  robot_->drive(30);
  EXPECT_TRUE(caughtUp());
  settle();
  EXPECT_GE(observer_->poses(), 20);
  EXPECT_GE(observer_->landmarks(), 4u) << "the four walls";
  EXPECT_GT(observer_->mapToOdom(), 0);
}

TEST_F(FaultsTest, B_InvalidBeamsAreSkippedNotFitted) {
  const long bad_before = observer_->diagnostic("dropped: bad scan");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (float value : {nan, inf, -inf, 0.0f, 0.01f /* < range_min */, 50.0f /* > range_max */}) {
    robot_->tick();
    sensor_msgs::LaserScan msg = robot_->scan();
    for (size_t i = 0; i < msg.ranges.size(); i += 2) msg.ranges[i] = value;  // half the beams
    robot_->publish(msg);
    robot_->tick();
    msg = robot_->scan();
    for (float& r : msg.ranges) r = value;  // all of them
    robot_->publish(msg);
  }
  EXPECT_TRUE(caughtUp()) << "a scan whose beams are all invalid was not processed";
  settle();
  // Processed (no features from the invalid beams), not dropped as malformed.
  EXPECT_EQ(observer_->diagnostic("dropped: bad scan"), bad_before);
  EXPECT_EQ(observer_->nonFinite(), 0);
  expectRecovers("invalid beams");
}

TEST_F(FaultsTest, C_MalformedScanHeadersAreDroppedAndCounted) {
  const long bad_before = std::max(0L, observer_->diagnostic("dropped: bad scan"));
  int malformed = 0;
  for (int kind = 0; kind < 3; ++kind) {
    robot_->tick();
    sensor_msgs::LaserScan msg = robot_->scan();
    if (kind == 0) msg.angle_increment = 0.0f;
    if (kind == 1) msg.angle_increment = std::numeric_limits<float>::quiet_NaN();
    if (kind == 2) msg.angle_min = std::numeric_limits<float>::infinity();
    robot_->publish(msg);
    ++malformed;
  }
  // Usable oddities: an empty scan, a changed beam count, a zero range_max (unbounded), an
  // increment inconsistent with angle_max (warned, bearings from angle_min + i * increment),
  // and a reversed scan.
  for (int kind = 0; kind < 5; ++kind) {
    robot_->tick();
    sensor_msgs::LaserScan msg = robot_->scan();
    if (kind == 0) msg.ranges.clear();
    if (kind == 1) {
      sensor_msgs::LaserScan half = msg;
      half.ranges.clear();
      for (size_t i = 0; i < msg.ranges.size(); i += 2) half.ranges.push_back(msg.ranges[i]);
      half.angle_increment = 2.0f * msg.angle_increment;
      msg = half;
    }
    if (kind == 2) msg.range_max = 0.0f;
    if (kind == 3) msg.angle_max = msg.angle_min + 0.5f;
    if (kind == 4) {
      std::reverse(msg.ranges.begin(), msg.ranges.end());
      std::swap(msg.angle_min, msg.angle_max);
      msg.angle_increment = -msg.angle_increment;
    }
    robot_->publish(msg);
  }
  EXPECT_TRUE(caughtUp()) << "the reversed scan (usable) was not processed";
  settle();
  EXPECT_EQ(observer_->diagnostic("dropped: bad scan"), bad_before + malformed);
  EXPECT_EQ(observer_->nonFinite(), 0);
  expectRecovers("malformed scans");
}

TEST_F(FaultsTest, D_DuplicateOldAndZeroStampsAreDropped) {
  const long stale_before = std::max(0L, observer_->diagnostic("dropped: stamp not after the last"));
  const long same_before = std::max(0L, observer_->diagnostic("frames at the last frame's stamp"));
  robot_->tick();
  const sensor_msgs::LaserScan good = robot_->scan();
  robot_->publish(good);
  robot_->publish(good);  // the same stamp again: skipped and counted, not an error
  EXPECT_TRUE(caughtUp());
  settle();
  const double last = observer_->lastPoseStamp();
  sensor_msgs::LaserScan old = robot_->scan();
  old.header.stamp = ros::Time(robot_->time() - 3.0 * kStep);  // older, but tf still has it
  robot_->publish(old);
  settle();
  EXPECT_GE(observer_->diagnostic("dropped: stamp not after the last"), stale_before + 1);
  EXPECT_EQ(observer_->diagnostic("frames at the last frame's stamp"), same_before + 1);
  sensor_msgs::LaserScan zero = robot_->scan();
  zero.header.stamp = ros::Time(0.0);
  robot_->publish(zero);
  settle();
  EXPECT_DOUBLE_EQ(observer_->lastPoseStamp(), last) << "an old or zero stamp made an update";
  EXPECT_EQ(observer_->nonFinite(), 0);
  expectRecovers("out-of-order stamps");
}

TEST_F(FaultsTest, E_UnknownAndEmptyFramesAreDropped) {
  const long empty_before = std::max(0L, observer_->diagnostic("dropped: empty frame_id"));
  const long updates_before = observer_->poses();
  robot_->tick();
  sensor_msgs::LaserScan msg = robot_->scan();
  msg.header.frame_id = "";
  robot_->publish(msg);
  msg.header.frame_id = "no_such_laser";
  for (int i = 0; i < 3; ++i) {
    robot_->tick();
    msg.header.stamp = ros::Time(robot_->time());
    robot_->publish(msg);
  }
  settle();
  EXPECT_EQ(observer_->diagnostic("dropped: empty frame_id"), empty_before + 1);
  EXPECT_EQ(observer_->poses(), updates_before) << "a scan in an unknown frame was used";
  expectRecovers("unknown frames");
  EXPECT_EQ(observer_->diagnostic("dropped: frame not in tf"), 3)
      << "the scans in frame no_such_laser";
}

TEST_F(FaultsTest, E2_FramesWithALeadingSlashAreUsed) {
  // Old drivers and bags write "/laser"; tf2 refuses such names, so the node must strip it.
  const long unknown_before = std::max(0L, observer_->diagnostic("dropped: frame not in tf"));
  const long lookups_before = std::max(0L, observer_->diagnostic("dropped: tf lookup failed"));
  for (int i = 0; i < 4; ++i) {
    robot_->tick();
    sensor_msgs::LaserScan msg = robot_->scan();
    msg.header.frame_id = "/laser";
    robot_->publish(msg);
  }
  EXPECT_TRUE(caughtUp()) << "scans in frame /laser were not used (last pose at "
                          << observer_->lastPoseStamp() << ", now " << robot_->time() << ")";
  settle();
  EXPECT_EQ(std::max(0L, observer_->diagnostic("dropped: frame not in tf")), unknown_before);
  EXPECT_EQ(std::max(0L, observer_->diagnostic("dropped: tf lookup failed")), lookups_before);
}

TEST_F(FaultsTest, F_MissingOdometryTfIsWaitedForThenDropped) {
  const long map_to_odom_before = observer_->mapToOdom();
  const double pose_before = observer_->lastPoseStamp();
  for (int i = 0; i < 8; ++i) {  // 4 s of scans without odom -> base_link
    robot_->tick(false);
    robot_->publish(robot_->scan());
  }
  settle();
  EXPECT_DOUBLE_EQ(observer_->lastPoseStamp(), pose_before) << "updated without odometry";
  EXPECT_GT(observer_->mapToOdom(), map_to_odom_before)
      << "map -> odom must keep being published through a tf outage";
  expectRecovers("a tf outage");
}

TEST_F(FaultsTest, G_OdometryJumpIsSurvived) {
  robot_->jumpOdometry(5.0);  // the wheel odometry jumps 5 m at once (as in intel.bag)
  robot_->drive(10);
  EXPECT_TRUE(caughtUp());
  settle();
  EXPECT_EQ(observer_->nonFinite(), 0);
}

// Every input (scans, sonar, features) goes through the same tf gate; the features topic
// shows it here, with non-finite and absurd features next to a good one.
TEST_F(FaultsTest, G2_FeaturesInAnUnknownFrameOrNonFiniteAreDropped) {
  const long unknown_before = std::max(0L, observer_->diagnostic("dropped: frame not in tf"));
  robot_->tick();
  FeatureArray msg;
  msg.header.stamp = ros::Time(robot_->time());
  msg.header.frame_id = "no_such_sensor";
  PointFeature good;
  good.range = 2.0;
  good.bearing = 0.5;
  good.covariance = {0.01, 0.0, 0.0, 0.001};
  good.id = -1;
  msg.points.push_back(good);
  robot_->publish(msg);
  settle();
  EXPECT_EQ(observer_->diagnostic("dropped: frame not in tf"), unknown_before + 1);
  robot_->tick();
  msg.header.stamp = ros::Time(robot_->time());
  msg.header.frame_id = "base_link";
  PointFeature bad = good;
  bad.range = std::numeric_limits<double>::quiet_NaN();
  msg.points.push_back(bad);
  bad = good;
  bad.covariance = {std::numeric_limits<double>::infinity(), 0.0, 0.0, 1.0};
  msg.points.push_back(bad);
  LineFeature line;
  line.rho = -3.0;  // a negative rho is normalised, not rejected
  line.theta = 0.3;
  line.covariance = {0.0, 0.0, 0.0, 0.0};  // zero: the filter's floors apply
  line.start.x = 3.0;
  line.end.x = 3.5;
  msg.lines.push_back(line);
  robot_->publish(msg);
  EXPECT_TRUE(caughtUp()) << "the frame with two bad features was not used at all";
  settle();
  EXPECT_EQ(observer_->nonFinite(), 0);
  expectRecovers("bad features");
}

// tf2_ros's own listener let a /tf stamp near 2^32 s (a driver's -1) throw from its thread,
// which ended the node; the node's listener refuses such transforms (and a NaN, an unnamed
// frame, a stamp two days after the transforms so far, which would make tf2 drop every real
// one as old) and counts them, and uses the good transform of the same message.
TEST_F(FaultsTest, G3_UnusableTransformsOnTfAreRefusedAndCounted) {
  const long refused_before = std::max(0L, observer_->diagnostic("dropped: refused transform"));
  robot_->tick(false);  // this step's odometry comes only in the message below, after the bad
  tf2_msgs::TFMessage msg;
  const core::Pose2 away(0.5, 0.2, 0.1);
  geometry_msgs::TransformStamped far =
      rosbridge::toTransformStamped(away, "odom", "base_link", ros::Time(4294967295u, 0u));
  geometry_msgs::TransformStamped nan =
      rosbridge::toTransformStamped(away, "odom", "base_link", ros::Time(robot_->time()));
  nan.transform.translation.y = std::numeric_limits<double>::quiet_NaN();
  geometry_msgs::TransformStamped unnamed =
      rosbridge::toTransformStamped(away, "odom", "", ros::Time(robot_->time()));
  geometry_msgs::TransformStamped ahead =  // two days after the transforms so far
      rosbridge::toTransformStamped(away, "odom", "base_link", ros::Time(robot_->time() + 172800.0));
  msg.transforms = {far, nan, unnamed, ahead, robot_->odometry()};
  robot_->publishTf(msg);
  // A scan stamped more than 2^31 s after the tf data (under the 4.2e9 s of farStampProblem):
  // tf2's extrapolation arithmetic overflows a ros::Duration for it.
  sensor_msgs::LaserScan distant = robot_->scan();
  distant.header.stamp = ros::Time(3.0e9);
  robot_->publish(distant);
  robot_->publish(robot_->scan());  // needs the good transform of the message
  EXPECT_TRUE(caughtUp()) << "no update after the refused transforms: the good one of their "
                             "message was not used, or a bad one spoilt tf";
  settle();
  EXPECT_EQ(observer_->diagnostic("dropped: refused transform"), refused_before + 4);
  EXPECT_EQ(observer_->nonFinite(), 0);
  expectRecovers("unusable transforms on /tf");
}

TEST_F(FaultsTest, H_ClockJumpBackClearsTheMapAndMappingRestarts) {
  const long resets_before = std::max(0L, observer_->diagnostic("resets"));
  ASSERT_GE(observer_->landmarks(), 4u);
  robot_->restartClockAt(1.0);
  observer_->newClockEpoch();
  robot_->drive(2);  // the first scan after the jump triggers the reset
  EXPECT_TRUE(caughtUp());
  settle();
  EXPECT_EQ(observer_->diagnostic("resets"), resets_before + 1);
  robot_->drive(20);
  EXPECT_TRUE(caughtUp()) << "no mapping after the loop";
  settle();
  EXPECT_GE(observer_->landmarks(), 4u) << "the walls were not mapped again";
}

// laser_fastslam2.yaml has max_time_gap 30 s: a gap is odometry silent that long, not scans.
TEST_F(FaultsTest, I_NoScansWhileOdometryFlowsIsNoGapAnOdometryOutageIs) {
  settle();
  const long gaps_before = observer_->diagnostic("odometry gaps");
  ASSERT_GE(gaps_before, 0) << "no 'odometry gaps' in /diagnostics";
  for (int i = 0; i < 70; ++i) robot_->tick();  // 35 s of odometry without a scan
  robot_->drive(2);
  EXPECT_TRUE(caughtUp());
  settle();
  EXPECT_EQ(observer_->diagnostic("odometry gaps"), gaps_before) << "35 s without scans";
  for (int i = 0; i < 70; ++i) robot_->tick(false);  // 35 s without odometry (nor scans)
  robot_->drive(2);
  EXPECT_TRUE(caughtUp());
  settle();
  EXPECT_EQ(observer_->diagnostic("odometry gaps"), gaps_before + 1) << "35 s without odometry";
  expectRecovers("an odometry outage");
}

TEST_F(FaultsTest, Z_NothingNonFiniteAndNoRepeatedTransformStamps) {
  EXPECT_EQ(observer_->nonFinite(), 0);
  EXPECT_EQ(observer_->repeatedTf(), 0) << "map -> odom published twice with one stamp";
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "faults_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return result;
}
