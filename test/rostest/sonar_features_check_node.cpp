// sonar_features.test: the sonar_features node on a simulated test_small bag publishes
// FeatureArray messages in the base frame, with lines, finite values and increasing stamps.

#include <gtest/gtest.h>
#include <rbpf_slam/FeatureArray.h>
#include <ros/ros.h>

#include <cmath>
#include <mutex>
#include <string>

namespace rbpf_slam {
namespace {

struct Seen {
  std::mutex mutex;
  int messages = 0, with_lines = 0, lines = 0, points = 0, non_finite = 0, out_of_order = 0;
  std::string frame;
  double last_stamp = 0.0;
};

TEST(SonarFeatures, PublishesFiniteLinesInTheBaseFrame) {
  ros::NodeHandle nh, pnh("~");
  const double timeout = pnh.param("timeout", 120.0);
  const int min_messages = pnh.param("min_messages", 10);
  Seen seen;
  ros::Subscriber sub = nh.subscribe<FeatureArray>(
      "sonar_features_out", 100, [&seen](const FeatureArray::ConstPtr& msg) {
        std::lock_guard<std::mutex> lock(seen.mutex);
        ++seen.messages;
        seen.frame = msg->header.frame_id;
        const double stamp = msg->header.stamp.toSec();
        if (stamp <= seen.last_stamp) ++seen.out_of_order;
        seen.last_stamp = stamp;
        if (!msg->lines.empty()) ++seen.with_lines;
        seen.lines += static_cast<int>(msg->lines.size());
        seen.points += static_cast<int>(msg->points.size());
        for (const auto& l : msg->lines) {
          if (!std::isfinite(l.rho) || !std::isfinite(l.theta) || l.rho < 0.0) ++seen.non_finite;
          for (double c : l.covariance) seen.non_finite += !std::isfinite(c);
        }
        for (const auto& p : msg->points) {
          if (!std::isfinite(p.range) || !std::isfinite(p.bearing)) ++seen.non_finite;
        }
      });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::WallTime::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(seen.mutex);
      if (seen.with_lines >= min_messages) break;
    }
    ros::WallDuration(0.1).sleep();
  }
  std::lock_guard<std::mutex> lock(seen.mutex);
  EXPECT_GE(seen.with_lines, min_messages) << seen.messages << " messages, " << seen.lines
                                           << " lines, " << seen.points << " points";
  EXPECT_EQ(seen.frame, "base_link");
  EXPECT_EQ(seen.non_finite, 0);
  EXPECT_EQ(seen.out_of_order, 0);
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "sonar_features_check");
  ros::AsyncSpinner spinner(1);
  spinner.start();
  return RUN_ALL_TESTS();
}
