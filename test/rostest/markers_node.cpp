// Landmark markers, particle poses and trajectory messages (no roscore needed; run by
// markers.test so that it sits with the other ROS-layer tests).

#include <gtest/gtest.h>
#include <ros/time.h>

#include <cmath>
#include <limits>

#include "rbpf_slam/ros/markers.h"

namespace rbpf_slam {
namespace {

using visualization_msgs::Marker;

core::LandmarkEstimate line(int id) {
  core::LandmarkEstimate l;
  l.id = id;
  l.type = core::LandmarkType::kLine;
  l.mean << 2.0, 0.0;  // x = 2
  l.start << 2.0, -1.0;
  l.end << 2.0, 1.0;
  return l;
}

core::LandmarkEstimate point(int id, double x, double y) {
  core::LandmarkEstimate p;
  p.id = id;
  p.type = core::LandmarkType::kPoint;
  p.mean << x, y;
  p.covariance << 0.04, 0.0, 0.0, 0.01;
  return p;
}

std_msgs::Header mapHeader() {
  std_msgs::Header h;
  h.frame_id = "map";
  h.stamp = ros::Time(100.0);
  return h;
}

int count(const visualization_msgs::MarkerArray& a, const std::string& ns, int action) {
  int n = 0;
  for (const auto& m : a.markers) n += m.ns == ns && m.action == action;
  return n;
}

TEST(LandmarkMarkers, LinesAreSegmentsAndPointsHaveEllipses) {
  rosbridge::LandmarkMarkers markers;
  const auto a = markers.update({line(3), point(7, 1.0, 2.0)}, mapHeader());
  ASSERT_EQ(a.markers.size(), 3u);
  for (const auto& m : a.markers) EXPECT_EQ(m.header.frame_id, "map");
  const Marker& l = a.markers[0];
  EXPECT_EQ(l.ns, "lines");
  EXPECT_EQ(l.id, 3);
  EXPECT_EQ(l.type, Marker::LINE_LIST);
  ASSERT_EQ(l.points.size(), 2u);
  EXPECT_DOUBLE_EQ(l.points[0].y, -1.0);
  EXPECT_DOUBLE_EQ(l.points[1].y, 1.0);
  EXPECT_EQ(a.markers[1].type, Marker::SPHERE);
  EXPECT_EQ(a.markers[1].id, 7);
  EXPECT_EQ(a.markers[2].ns, "point_covariance");
  EXPECT_EQ(a.markers[2].type, Marker::LINE_STRIP);
  EXPECT_EQ(a.markers[2].id, 7);
  EXPECT_NE(a.markers[0].color.b, a.markers[1].color.b);  // coloured by type
}

TEST(LandmarkMarkers, DeletesWhatDisappeared) {
  rosbridge::LandmarkMarkers markers;
  markers.update({line(1), line(2), point(5, 0.0, 0.0)}, mapHeader());
  const auto a = markers.update({line(2)}, mapHeader());
  EXPECT_EQ(count(a, "lines", Marker::ADD), 1);
  EXPECT_EQ(count(a, "lines", Marker::DELETE), 1);
  EXPECT_EQ(count(a, "points", Marker::DELETE), 1);
  EXPECT_EQ(count(a, "point_covariance", Marker::DELETE), 1);
  for (const auto& m : a.markers) {
    if (m.action == Marker::DELETE && m.ns == "lines") {
      EXPECT_EQ(m.id, 1);
    }
  }
  const auto b = markers.update({line(2)}, mapHeader());  // nothing left to delete
  EXPECT_EQ(count(b, "lines", Marker::DELETE), 0);
  const auto c = markers.update({}, mapHeader());
  EXPECT_EQ(count(c, "lines", Marker::DELETE), 1);
}

TEST(LandmarkMarkers, NonFiniteLandmarksAreLeftOut) {
  rosbridge::LandmarkMarkers markers;
  auto bad = point(4, std::numeric_limits<double>::quiet_NaN(), 0.0);
  const auto a = markers.update({bad, line(1)}, mapHeader());
  ASSERT_EQ(a.markers.size(), 1u);
  EXPECT_EQ(a.markers[0].ns, "lines");
}

TEST(CovarianceEllipse, TwoSigmaAxesFollowTheEigenvectors) {
  Eigen::Matrix2d cov;
  const double angle = 0.3;
  Eigen::Matrix2d r;
  r << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  cov = r * Eigen::Vector2d(0.25, 0.04).asDiagonal() * r.transpose();  // sigmas 0.5, 0.2
  const auto points = rosbridge::covarianceEllipse(Eigen::Vector2d(1.0, -1.0), cov, 2.0, 32);
  ASSERT_EQ(points.size(), 33u);
  EXPECT_TRUE(points.front().isApprox(points.back()));
  double max_r = 0.0, min_r = 1e9;
  for (const auto& p : points) {
    const double d = (p - Eigen::Vector2d(1.0, -1.0)).norm();
    max_r = std::max(max_r, d);
    min_r = std::min(min_r, d);
  }
  EXPECT_NEAR(max_r, 1.0, 1e-9);  // 2 * 0.5
  EXPECT_NEAR(min_r, 0.4, 1e-2);  // 2 * 0.2 (sampled)
  const Eigen::Vector2d major = points.front() - Eigen::Vector2d(1.0, -1.0);
  EXPECT_NEAR(std::atan2(major.y(), major.x()), angle, 1e-9);
  EXPECT_TRUE(
      rosbridge::covarianceEllipse(Eigen::Vector2d::Zero(), Eigen::Matrix2d::Constant(NAN), 2.0, 32)
          .empty());
}

TEST(ToPoseArray, SkipsNonFinitePoses) {
  std::vector<core::WeightedPose> particles(3);
  particles[1].pose << 1.0, 2.0, 0.5;
  particles[2].pose << NAN, 0.0, 0.0;
  const auto a = rosbridge::toPoseArray(particles, mapHeader());
  ASSERT_EQ(a.poses.size(), 2u);
  EXPECT_DOUBLE_EQ(a.poses[1].position.y, 2.0);
  EXPECT_NEAR(a.poses[1].orientation.z, std::sin(0.25), 1e-12);
}

TEST(ToPath, StampsAndFrames) {
  std::vector<core::TrajectoryPoint> trajectory(2);
  trajectory[0].stamp = 10.0;
  trajectory[1].stamp = 12.5;
  trajectory[1].pose << 3.0, 4.0, 0.0;
  const auto path = rosbridge::toPath(trajectory, "map");
  ASSERT_EQ(path.poses.size(), 2u);
  EXPECT_EQ(path.header.frame_id, "map");
  EXPECT_DOUBLE_EQ(path.header.stamp.toSec(), 12.5);
  EXPECT_DOUBLE_EQ(path.poses[1].pose.position.x, 3.0);
  EXPECT_TRUE(rosbridge::toPath({}, "map").poses.empty());
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
