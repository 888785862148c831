// Fault injection for the sonar front end (sonar_faults.test): rbpf_slam_node with the sonar
// config and the sonar_features node both read /sonar. This node is the robot: it owns /clock,
// broadcasts odom -> base_link and base_link -> sonar_0..7 (a Pioneer-style front ring), and
// publishes the nearest wall echo inside each transducer's 30 deg cone in a rectangular room.
// Between stretches of good data it injects one fault class at a time and checks the named
// outcome on both nodes: invalid ranges (NaN, +-inf, zero, negative, max-range, beyond max)
// are no echo and never become features; malformed readings, unknown and empty frames and old
// stamps are dropped and counted on /diagnostics under their cause; after each fault the
// nodes update again. Finally the clock jumps back (a bag loop): both start over.

#include <gtest/gtest.h>
#include <rbpf_slam/FeatureArray.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/Range.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <cmath>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

#include "fault_test_support.h"
#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/ros/conversions.h"

namespace rbpf_slam {
namespace {

using fault_test::Observer;

constexpr double kHalfX = 2.5, kHalfY = 2.0;  // the room: [-2.5, 2.5] x [-2, 2] m
constexpr double kStep = 0.25;                // s of simulated time per ring
constexpr double kRadius = 1.0, kSpeed = 0.3;  // the robot's circle, m and m/s
constexpr double kMaxRange = 5.0;
constexpr double kCone = 30.0 * M_PI / 180.0;
const double kRingDeg[] = {90, 50, 30, 10, -10, -30, -50, -90};
constexpr int kSonars = 8;
constexpr double kMountRadius = 0.15;
/// The robot stays at least this far from every wall (2.0 - kRadius - the mount radius), so
/// a feature closer than this to the base was made from an invalid echo.
constexpr double kNearestWall = 0.8;

/// The sonar_features node's output: how many messages, and whether any was non-finite or
/// put a feature closer than kNearestWall.
class FeaturesObserver {
 public:
  FeaturesObserver() {
    ros::NodeHandle nh;
    sub_ = nh.subscribe("/sonar_features_out", 100, &FeaturesObserver::onFeatures, this);
  }
  long messages() { std::lock_guard<std::mutex> l(m_); return messages_; }
  long lines() { std::lock_guard<std::mutex> l(m_); return lines_; }
  long bad() { std::lock_guard<std::mutex> l(m_); return bad_; }

 private:
  void onFeatures(const FeatureArray::ConstPtr& msg) {
    std::lock_guard<std::mutex> l(m_);
    ++messages_;
    for (const auto& line : msg->lines) {
      ++lines_;
      bool ok = std::isfinite(line.rho) && std::isfinite(line.theta) &&
                std::fabs(line.rho) >= kNearestWall;
      for (double c : line.covariance) ok = ok && std::isfinite(c);
      if (!ok) ++bad_;
    }
    for (const auto& point : msg->points) {
      bool ok = std::isfinite(point.range) && std::isfinite(point.bearing) &&
                point.range >= kNearestWall;
      for (double c : point.covariance) ok = ok && std::isfinite(c);
      if (!ok) ++bad_;
    }
  }
  std::mutex m_;
  ros::Subscriber sub_;
  long messages_ = 0, lines_ = 0, bad_ = 0;
};

/// The robot: drives a circle of radius 1 m at 0.3 m/s, with exact odometry, and sends one
/// ring of 8 Range messages per step.
class Robot {
 public:
  Robot() {
    ros::NodeHandle nh;
    clock_pub_ = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
    sonar_pub_ = nh.advertise<sensor_msgs::Range>("/sonar", 100);
    std::vector<geometry_msgs::TransformStamped> mounts;
    for (int i = 0; i < kSonars; ++i) {
      mounts.push_back(rosbridge::toTransformStamped(mount(i), "base_link",
                                                     "sonar_" + std::to_string(i), ros::Time(0.0)));
    }
    static_broadcaster_.sendTransform(mounts);
  }
  static core::Pose2 mount(int i) {
    const double a = kRingDeg[i] * M_PI / 180.0;
    return core::Pose2(kMountRadius * std::cos(a), kMountRadius * std::sin(a), a);
  }
  double time() const { return t_; }
  core::Pose2 truth(double t) const {
    const double w = kSpeed / kRadius;
    return core::Pose2(kRadius * std::cos(w * t), kRadius * std::sin(w * t),
                       core::wrapAngle(w * t + M_PI / 2));
  }
  /// Advances the clock one step and publishes odom -> base_link at the new time.
  void tick() {
    t_ += kStep;
    publishClock(t_);
    broadcaster_.sendTransform(
        rosbridge::toTransformStamped(truth(t_), "odom", "base_link", ros::Time(t_)));
    ros::WallDuration(0.03).sleep();
  }
  /// The correct ring at the current time: the nearest wall inside each cone.
  std::vector<sensor_msgs::Range> ring() const {
    std::vector<sensor_msgs::Range> ring;
    for (int i = 0; i < kSonars; ++i) {
      const core::Pose2 sensor = core::compose(truth(t_), mount(i));
      double nearest = kMaxRange;
      for (int k = -15; k <= 15; ++k) {
        nearest = std::min(nearest, fault_test::rangeToWall(sensor.x(), sensor.y(),
                                                            sensor.z() + k * kCone / 30.0,
                                                            kHalfX, kHalfY));
      }
      sensor_msgs::Range msg;
      msg.header.stamp = ros::Time(t_);
      msg.header.frame_id = "sonar_" + std::to_string(i);
      msg.radiation_type = sensor_msgs::Range::ULTRASOUND;
      msg.field_of_view = static_cast<float>(kCone);
      msg.min_range = 0.1f;
      msg.max_range = static_cast<float>(kMaxRange);
      msg.range = static_cast<float>(nearest);
      ring.push_back(msg);
    }
    return ring;
  }
  void publish(const std::vector<sensor_msgs::Range>& ring) {
    for (const auto& msg : ring) sonar_pub_.publish(msg);
    ros::WallDuration(0.05).sleep();
  }
  void publish(const sensor_msgs::Range& msg) { publish(std::vector<sensor_msgs::Range>{msg}); }
  void drive(int n) {
    for (int i = 0; i < n; ++i) {
      tick();
      publish(ring());
    }
  }
  void restartClockAt(double t) {
    t_ = t;
    publishClock(t_);
    ros::WallDuration(0.1).sleep();
  }
  /// Both nodes read /sonar, rbpf_slam_node reads /clock.
  bool subscribed() const {
    return sonar_pub_.getNumSubscribers() >= 2 && clock_pub_.getNumSubscribers() >= 2;
  }

 private:
  void publishClock(double t) {
    rosgraph_msgs::Clock clock;
    clock.clock = ros::Time(t);
    clock_pub_.publish(clock);
  }
  ros::Publisher clock_pub_, sonar_pub_;
  tf2_ros::TransformBroadcaster broadcaster_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
  double t_ = 1.0;
};

const std::string kSlam = "rbpf_slam_node";
const std::string kExtractor = "sonar_features";

class SonarFaultsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    observer_ = new Observer();
    features_ = new FeaturesObserver();
    robot_ = new Robot();
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
    while (!robot_->subscribed() && ros::WallTime::now() < deadline) {
      ros::WallDuration(0.1).sleep();
    }
  }
  /// Waits for reports of both nodes produced after everything sent so far was handled. A node
  /// that reports nothing for 15 s fails the test (the counters read next would be stale).
  static void settle() {
    ros::WallDuration(0.3).sleep();
    const ros::WallTime since = ros::WallTime::now();
    const ros::WallTime deadline = since + ros::WallDuration(15.0);
    while ((observer_->lastDiagnostics(kSlam) <= since ||
            observer_->lastDiagnostics(kExtractor) <= since) &&
           ros::WallTime::now() < deadline) {
      ros::WallDuration(0.05).sleep();
    }
    if (observer_->lastDiagnostics(kSlam) <= since)
      ADD_FAILURE() << "no slam /diagnostics for 15 s";
    if (observer_->lastDiagnostics(kExtractor) <= since) {
      ADD_FAILURE() << "no extractor /diagnostics for 15 s";
    }
  }
  /// A counter of a node's /diagnostics, 0 while it has not been reported.
  static long count(const std::string& key, const std::string& node) {
    return std::max(0L, observer_->diagnostic(key, node));
  }
  /// Good data after a fault: both nodes produce output again within a few extractions.
  static void expectRecovers(const std::string& after) {
    const long poses = observer_->poses(), features = features_->messages();
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(30.0);
    while ((observer_->poses() == poses || features_->messages() == features) &&
           ros::WallTime::now() < deadline) {
      robot_->drive(4);  // 0.3 m: one extraction
    }
    EXPECT_GT(observer_->poses(), poses) << "rbpf_slam_node: no update after " << after;
    EXPECT_GT(features_->messages(), features) << "sonar_features: no output after " << after;
    settle();
  }
  static Observer* observer_;
  static FeaturesObserver* features_;
  static Robot* robot_;
};
Observer* SonarFaultsTest::observer_ = nullptr;
FeaturesObserver* SonarFaultsTest::features_ = nullptr;
Robot* SonarFaultsTest::robot_ = nullptr;

// The tests run in declaration order on the same two nodes.

TEST_F(SonarFaultsTest, A_MapsTheRoomFromGoodEchoes) {
  ASSERT_TRUE(robot_->subscribed()) << "rbpf_slam_node and sonar_features did not subscribe";
  robot_->drive(80);  // 6 m, 20 extractions
  settle();
  EXPECT_GE(observer_->poses(), 10);
  EXPECT_GE(observer_->landmarks(), 2u) << "walls mapped from the sonar";
  EXPECT_GE(features_->lines(), 5) << "sonar_features found no walls";
  EXPECT_EQ(features_->bad(), 0);
  EXPECT_GE(count("updates", kExtractor), 10);
}

TEST_F(SonarFaultsTest, B_InvalidRangesAreNoEchoNeverFeatures) {
  const long bad_slam = count("dropped: bad sonar reading", kSlam);
  const long bad_extractor = count("dropped: bad sonar reading", kExtractor);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (float value : {nan, inf, -inf, 0.0f, -1.0f, 0.05f /* < min_range */,
                      static_cast<float>(kMaxRange), 40.0f /* > max_range */}) {
    for (int step = 0; step < 3; ++step) {
      robot_->tick();
      std::vector<sensor_msgs::Range> ring = robot_->ring();
      for (auto& msg : ring) msg.range = value;
      robot_->publish(ring);
    }
  }
  settle();
  // Valid messages with no usable echo: processed, not dropped as malformed.
  EXPECT_EQ(count("dropped: bad sonar reading", kSlam), bad_slam);
  EXPECT_EQ(count("dropped: bad sonar reading", kExtractor), bad_extractor);
  EXPECT_EQ(features_->bad(), 0) << "a feature from an invalid echo (or non-finite)";
  EXPECT_EQ(observer_->nonFinite(), 0);
  expectRecovers("invalid ranges");
}

TEST_F(SonarFaultsTest, C_MalformedReadingsAreDroppedAndCounted) {
  const long bad_slam = count("dropped: bad sonar reading", kSlam);
  const long bad_extractor = count("dropped: bad sonar reading", kExtractor);
  robot_->tick();
  sensor_msgs::Range msg = robot_->ring()[3];
  for (float fov : {std::numeric_limits<float>::quiet_NaN(), 0.0f, 4.0f}) {
    msg.field_of_view = fov;
    robot_->publish(msg);
  }
  settle();
  EXPECT_EQ(count("dropped: bad sonar reading", kSlam), bad_slam + 3);
  EXPECT_EQ(count("dropped: bad sonar reading", kExtractor), bad_extractor + 3);
  expectRecovers("malformed readings");
}

TEST_F(SonarFaultsTest, D_UnknownAndEmptyFramesAreDropped) {
  const long unknown_slam = count("dropped: frame not in tf", kSlam);
  const long unknown_extractor = count("dropped: frame not in tf", kExtractor);
  const long empty_slam = count("dropped: empty frame_id", kSlam);
  const long empty_extractor = count("dropped: empty frame_id", kExtractor);
  robot_->tick();
  sensor_msgs::Range msg = robot_->ring()[0];
  msg.header.frame_id = "sonar_9";  // not in tf
  for (int i = 0; i < 3; ++i) robot_->publish(msg);
  msg.header.frame_id = "";
  robot_->publish(msg);
  settle();
  EXPECT_EQ(count("dropped: frame not in tf", kSlam), unknown_slam + 3);
  EXPECT_EQ(count("dropped: frame not in tf", kExtractor), unknown_extractor + 3);
  EXPECT_EQ(count("dropped: empty frame_id", kSlam), empty_slam + 1);
  EXPECT_EQ(count("dropped: empty frame_id", kExtractor), empty_extractor + 1);
  expectRecovers("unknown and empty frames");
}

TEST_F(SonarFaultsTest, E_OldStampsAreDropped) {
  const long old_extractor = count("dropped: old stamp", kExtractor);
  const long resets_slam = count("resets", kSlam);
  robot_->drive(2);
  std::vector<sensor_msgs::Range> ring = robot_->ring();
  // More than a second (the window's limit) before the newest reading.
  for (auto& msg : ring) msg.header.stamp = ros::Time(robot_->time() - 6.0 * kStep);
  robot_->publish(ring);
  settle();
  EXPECT_EQ(count("dropped: old stamp", kExtractor), old_extractor + kSonars);
  // rbpf_slam_node: older than its last frame, so not used; a stale ring is no bag loop.
  EXPECT_EQ(count("resets", kSlam), resets_slam);
  EXPECT_EQ(observer_->nonFinite(), 0);
  expectRecovers("old stamps");
}

TEST_F(SonarFaultsTest, E2_ReadingsALittleOutOfOrderAreUsed) {
  // Transducers stamped 5 ms apart and published newest first (two drivers on one topic, a
  // relay): each reading is older than the one before it, but well inside the window.
  const long old_extractor = count("dropped: old stamp", kExtractor);
  const long old_slam = count("dropped: stamp not after the last", kSlam);
  robot_->drive(2);
  for (int ring_index = 0; ring_index < 3; ++ring_index) {
    robot_->tick();
    std::vector<sensor_msgs::Range> ring = robot_->ring();
    for (int i = 0; i < kSonars; ++i) {
      ring[i].header.stamp = ros::Time(robot_->time() - 0.005 * i);
    }
    robot_->publish(ring);
  }
  settle();
  EXPECT_EQ(count("dropped: old stamp", kExtractor), old_extractor);
  EXPECT_EQ(count("dropped: stamp not after the last", kSlam), old_slam);
  EXPECT_EQ(observer_->nonFinite(), 0);
  expectRecovers("readings a little out of order");
}

TEST_F(SonarFaultsTest, F_ClockJumpBackRestartsBothNodes) {
  const long resets_slam = count("resets", kSlam);
  const long resets_extractor = count("resets", kExtractor);
  robot_->restartClockAt(1.0);
  observer_->newClockEpoch();
  robot_->drive(8);
  settle();
  EXPECT_EQ(count("resets", kSlam), resets_slam + 1);
  EXPECT_EQ(count("resets", kExtractor), resets_extractor + 1);
  robot_->drive(60);
  settle();
  EXPECT_GE(observer_->landmarks(), 2u) << "the walls were not mapped again";
  expectRecovers("the clock jump");
}

TEST_F(SonarFaultsTest, Z_NothingNonFiniteAndNoRepeatedTransformStamps) {
  EXPECT_EQ(observer_->nonFinite(), 0);
  EXPECT_EQ(features_->bad(), 0);
  EXPECT_EQ(observer_->repeatedTf(), 0) << "map -> odom published twice with one stamp";
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "sonar_faults_test");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int result = RUN_ALL_TESTS();
  spinner.stop();
  ros::shutdown();
  return result;
}
