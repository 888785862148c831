// Landmark markers, particle poses and trajectory messages, and sensor mounts from tf (no
// roscore needed; run by markers.test so that it sits with the other ROS-layer tests).

#include <gtest/gtest.h>
#include <ros/time.h>
#include <tf2/LinearMath/Quaternion.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "rbpf_slam/ros/conversions.h"
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

/// The array without the DELETEALL that opens the first one.
visualization_msgs::MarkerArray withoutDeleteAll(visualization_msgs::MarkerArray a) {
  a.markers.erase(std::remove_if(a.markers.begin(), a.markers.end(),
                                 [](const Marker& m) { return m.action == Marker::DELETEALL; }),
                  a.markers.end());
  return a;
}

TEST(LandmarkMarkers, LinesAreSegmentsAndPointsHaveEllipses) {
  rosbridge::LandmarkMarkers markers;
  const auto a = withoutDeleteAll(markers.update({line(3), point(7, 1.0, 2.0)}, mapHeader()));
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

/// A restarted node (or a bag played again) must not leave the earlier run's markers in rviz
/// for ids the new run does not use: its first array opens with a DELETEALL, once.
TEST(LandmarkMarkers, TheFirstArrayClearsWhatAnEarlierRunShowed) {
  rosbridge::LandmarkMarkers markers;
  const auto a = markers.update({line(1)}, mapHeader());
  ASSERT_FALSE(a.markers.empty());
  EXPECT_EQ(a.markers.front().action, Marker::DELETEALL);
  EXPECT_EQ(a.markers.front().header.frame_id, "map");
  EXPECT_EQ(count(a, "lines", Marker::ADD), 1);
  const auto b = markers.update({line(1)}, mapHeader());
  for (const auto& m : b.markers) EXPECT_NE(m.action, Marker::DELETEALL);
  // Even an empty first map clears the display.
  rosbridge::LandmarkMarkers empty;
  const auto c = empty.update({}, mapHeader());
  ASSERT_EQ(c.markers.size(), 1u);
  EXPECT_EQ(c.markers[0].action, Marker::DELETEALL);
  // After clear() the publisher no longer knows what is shown: clear it all again.
  markers.clear();
  const auto d = markers.update({line(2)}, mapHeader());
  ASSERT_FALSE(d.markers.empty());
  EXPECT_EQ(d.markers.front().action, Marker::DELETEALL);
  EXPECT_EQ(count(d, "lines", Marker::DELETE), 0);
}

TEST(LandmarkMarkers, NonFiniteLandmarksAreLeftOut) {
  rosbridge::LandmarkMarkers markers;
  auto bad = point(4, std::numeric_limits<double>::quiet_NaN(), 0.0);
  const auto a = withoutDeleteAll(markers.update({bad, line(1)}, mapHeader()));
  ASSERT_EQ(a.markers.size(), 1u);
  EXPECT_EQ(a.markers[0].ns, "lines");
}

geometry_msgs::Transform mountRpy(double roll, double pitch, double yaw, double scale = 1.0) {
  // q = yaw (z) * pitch (y) * roll (x), optionally not of unit length.
  const double cr = std::cos(0.5 * roll), sr = std::sin(0.5 * roll);
  const double cp = std::cos(0.5 * pitch), sp = std::sin(0.5 * pitch);
  const double cy = std::cos(0.5 * yaw), sy = std::sin(0.5 * yaw);
  geometry_msgs::Transform t;
  t.translation.x = 0.2;
  t.translation.y = -0.1;
  t.rotation.w = scale * (cr * cp * cy + sr * sp * sy);
  t.rotation.x = scale * (sr * cp * cy - cr * sp * sy);
  t.rotation.y = scale * (cr * sp * cy + sr * cp * sy);
  t.rotation.z = scale * (cr * cp * sy - sr * sp * cy);
  return t;
}

TEST(SensorMount, LevelUpsideDownAndTiltedMounts) {
  const double deg = M_PI / 180.0;
  const auto level = rosbridge::toSensorMount(mountRpy(0.0, 0.0, 0.5));
  EXPECT_FALSE(level.upside_down);
  EXPECT_NEAR(level.tilt_rad, 0.0, 1e-6);
  EXPECT_FALSE(rosbridge::isTilted(level));
  EXPECT_NEAR(level.pose.x(), 0.2, 1e-12);
  EXPECT_NEAR(level.pose.z(), 0.5, 1e-9);
  // Upside down (rolled by pi): not tilted, and the pose keeps the x axis' direction.
  const auto flipped = rosbridge::toSensorMount(mountRpy(M_PI, 0.0, 0.5));
  EXPECT_TRUE(flipped.upside_down);
  EXPECT_NEAR(flipped.tilt_rad, 0.0, 1e-6);
  EXPECT_FALSE(rosbridge::isTilted(flipped));
  EXPECT_NEAR(flipped.pose.z(), 0.5, 1e-9);
  // Pitched 10 deg (a laser looking down), a non-unit quaternion: tilted, said with the angle.
  const auto pitched = rosbridge::toSensorMount(mountRpy(0.0, 10.0 * deg, 0.5, 3.0));
  EXPECT_FALSE(pitched.upside_down);
  EXPECT_NEAR(pitched.tilt_rad, 10.0 * deg, 1e-6);
  EXPECT_TRUE(rosbridge::isTilted(pitched));
  const std::string warning = rosbridge::tiltWarning("front_laser", pitched);
  EXPECT_NE(warning.find("front_laser"), std::string::npos) << warning;
  EXPECT_NE(warning.find("10.0 deg from level"), std::string::npos) << warning;
  // Upside down and rolled a further 8 deg: tilted from upside down.
  const auto both = rosbridge::toSensorMount(mountRpy(M_PI - 8.0 * deg, 0.0, 0.0));
  EXPECT_TRUE(both.upside_down);
  EXPECT_NEAR(both.tilt_rad, 8.0 * deg, 1e-6);
  EXPECT_NE(rosbridge::tiltWarning("l", both).find("from upside down"), std::string::npos);
  // 3 deg is within the level tolerance; a zero quaternion reads as level.
  EXPECT_FALSE(rosbridge::isTilted(rosbridge::toSensorMount(mountRpy(3.0 * deg, 0.0, 0.0))));
  geometry_msgs::Transform zero;
  EXPECT_FALSE(rosbridge::isTilted(rosbridge::toSensorMount(zero)));
}

sensor_msgs::PointCloud2 cloud2(const std::vector<std::array<float, 3>>& points) {
  sensor_msgs::PointCloud2 c;
  c.header.frame_id = "base_link";
  c.header.stamp = ros::Time(5.0);
  c.height = 1;
  c.width = static_cast<uint32_t>(points.size());
  const char* names[] = {"x", "y", "z", "intensity"};
  for (uint32_t i = 0; i < 4; ++i) {
    sensor_msgs::PointField f;
    f.name = names[i];
    f.offset = 4 * i;
    f.datatype = sensor_msgs::PointField::FLOAT32;
    f.count = 1;
    c.fields.push_back(f);
  }
  c.point_step = 16;
  c.row_step = c.point_step * c.width;
  for (const auto& p : points) {
    const float values[4] = {p[0], p[1], p[2], 1.0f};
    const auto* bytes = reinterpret_cast<const uint8_t*>(values);
    c.data.insert(c.data.end(), bytes, bytes + 16);
  }
  return c;
}

TEST(PointCloud2, ConvertsToThePointsOfAPointCloud) {
  sensor_msgs::PointCloud out;
  std::string error;
  ASSERT_TRUE(
      rosbridge::toPointCloud(cloud2({{1.5f, -2.0f, 0.2f}, {0.0f, 3.25f, 0.0f}}), &out, &error))
      << error;
  EXPECT_EQ(out.header.frame_id, "base_link");
  EXPECT_EQ(out.header.stamp, ros::Time(5.0));
  ASSERT_EQ(out.points.size(), 2u);
  EXPECT_FLOAT_EQ(out.points[0].x, 1.5f);
  EXPECT_FLOAT_EQ(out.points[0].y, -2.0f);
  EXPECT_FLOAT_EQ(out.points[0].z, 0.2f);
  EXPECT_FLOAT_EQ(out.points[1].y, 3.25f);
  // Broken clouds are refused with a reason, never read past their data.
  auto truncated = cloud2({{1.0f, 2.0f, 0.0f}, {3.0f, 4.0f, 0.0f}});
  truncated.data.resize(20);
  EXPECT_FALSE(rosbridge::toPointCloud(truncated, &out, &error));
  EXPECT_NE(error.find("too few for 2 x 1 points"), std::string::npos) << error;
  // Sizes that overflow a 64-bit product are refused, not allocated.
  auto huge = cloud2({{1.0f, 2.0f, 0.0f}});
  huge.width = huge.height = 1u << 24;
  huge.point_step = 1u << 16;
  huge.row_step = 0;
  huge.fields[0].offset = 0;
  EXPECT_FALSE(rosbridge::toPointCloud(huge, &out, &error));
  // Two rows padded to 40 bytes: the second row starts at row_step, not at width x point_step.
  auto padded =
      cloud2({{1.0f, 2.0f, 0.0f}, {3.0f, 4.0f, 0.0f}, {5.0f, 6.0f, 0.0f}, {7.0f, 8.0f, 0.0f}});
  padded.width = 2;
  padded.height = 2;
  padded.row_step = 40;
  padded.data.insert(padded.data.begin() + 32, 8, 0);  // pad row 0
  padded.data.insert(padded.data.end(), 8, 0);         // pad row 1
  ASSERT_TRUE(rosbridge::toPointCloud(padded, &out, &error)) << error;
  ASSERT_EQ(out.points.size(), 4u);
  EXPECT_FLOAT_EQ(out.points[2].x, 5.0f);
  EXPECT_FLOAT_EQ(out.points[3].y, 8.0f);
  auto no_y = cloud2({{1.0f, 2.0f, 0.0f}});
  no_y.fields[1].name = "v";
  EXPECT_FALSE(rosbridge::toPointCloud(no_y, &out, &error));
  EXPECT_NE(error.find("x and y"), std::string::npos) << error;
  auto outside = cloud2({{1.0f, 2.0f, 0.0f}});
  outside.fields[0].offset = 14;  // x would run past point_step
  EXPECT_FALSE(rosbridge::toPointCloud(outside, &out, &error));
  auto big_endian = cloud2({{1.0f, 2.0f, 0.0f}});
  big_endian.is_bigendian = true;
  EXPECT_FALSE(rosbridge::toPointCloud(big_endian, &out, &error));
}

/// Features in a frame mounted upside down (rolled by pi, then turned): where they are in the
/// base frame is what the full 3D rotation of tf says. Before session 13 only the yaw was used,
/// so bearings and line normals came out mirrored.
TEST(FeatureConversion, AnUpsideDownFrameMirrorsBearingsAndLines) {
  const geometry_msgs::Transform t = mountRpy(M_PI, 0.0, 0.5);
  const auto mount = rosbridge::toSensorMount(t);
  ASSERT_TRUE(mount.upside_down);
  const tf2::Quaternion q(t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w);
  auto toBase = [&](double x, double y) {
    const tf2::Vector3 v = tf2::quatRotate(q, tf2::Vector3(x, y, 0.0));
    return Eigen::Vector2d(v.x() + t.translation.x, v.y() + t.translation.y);
  };
  rbpf_slam::FeatureArray msg;
  rbpf_slam::PointFeature p;
  p.range = 2.0;
  p.bearing = 0.3;
  p.covariance = {0.01, 0.002, 0.002, 0.001};
  p.id = -1;
  msg.points.push_back(p);
  rbpf_slam::LineFeature l;  // the line x = 1.5 of the frame, from y = -1 to y = 2
  l.rho = 1.5;
  l.theta = 0.0;
  l.covariance = {0.01, 0.001, 0.001, 0.002};
  l.start.x = 1.5;
  l.start.y = -1.0;
  l.end.x = 1.5;
  l.end.y = 2.0;
  msg.lines.push_back(l);
  int dropped = 0;
  const core::FeatureSet set =
      rosbridge::toFeatureSet(msg, mount.pose, &dropped, mount.upside_down);
  ASSERT_EQ(set.points.size(), 1u);
  ASSERT_EQ(set.lines.size(), 1u);
  const Eigen::Vector2d point = toBase(2.0 * std::cos(0.3), 2.0 * std::sin(0.3));
  const auto& f = set.points[0];
  EXPECT_NEAR(f.range * std::cos(f.bearing), point.x(), 1e-9);
  EXPECT_NEAR(f.range * std::sin(f.bearing), point.y(), 1e-9);
  EXPECT_NEAR(f.covariance(0, 1), -0.002, 1e-12);  // the bearing turns the other way
  const auto& line = set.lines[0];
  const Eigen::Vector2d a = toBase(1.5, -1.0), b = toBase(1.5, 2.0);
  EXPECT_NEAR((line.start - a).norm(), 0.0, 1e-9);
  EXPECT_NEAR((line.end - b).norm(), 0.0, 1e-9);
  // Both end points lie on the converted line: rho = x cos(theta) + y sin(theta).
  for (const Eigen::Vector2d& e : {a, b}) {
    EXPECT_NEAR(e.x() * std::cos(line.theta) + e.y() * std::sin(line.theta), line.rho, 1e-9);
  }
}

// All zero is unset and fine; a set covariance that is not positive definite is counted (the
// filters use their noise floors for it, and the nodes say so).
TEST(FeatureConversion, CountsCovariancesThatAreSetButNotPositiveDefinite) {
  FeatureArray msg;
  auto point = [&msg](double c00, double c01, double c11) {
    PointFeature p;
    p.range = 2.0;
    p.bearing = 0.1;
    p.covariance = {c00, c01, c01, c11};
    p.id = -1;
    msg.points.push_back(p);
  };
  point(0.0, 0.0, 0.0);     // unset
  point(0.01, 0.0, 0.001);  // fine
  point(0.01, 0.1, 0.001);  // indefinite: a positive diagonal alone
  point(-0.01, 0.0, 0.001);
  LineFeature l;
  l.rho = 1.0;
  l.theta = 0.2;
  l.covariance = {0.01, 0.0, 0.0, 0.0};  // singular
  msg.lines.push_back(l);
  int dropped = 0;
  const core::FeatureSet set = rosbridge::toFeatureSet(msg, core::Pose2::Zero(), &dropped);
  EXPECT_EQ(dropped, 0);
  EXPECT_EQ(rosbridge::countUnusableCovariances(set), 3);
}

TEST(FeatureConversion, AnUpsideDownCloudFrameMirrorsItsPoints) {
  const geometry_msgs::Transform t = mountRpy(M_PI, 0.0, 0.5);
  const auto mount = rosbridge::toSensorMount(t);
  const tf2::Quaternion q(t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w);
  sensor_msgs::PointCloud cloud;
  geometry_msgs::Point32 p;
  p.x = 1.0f;
  p.y = 0.5f;
  cloud.points.push_back(p);
  const auto points = rosbridge::toBasePoints(cloud, mount.pose, mount.upside_down);
  ASSERT_EQ(points.size(), 1u);
  const tf2::Vector3 v = tf2::quatRotate(q, tf2::Vector3(1.0, 0.5, 0.0));
  EXPECT_NEAR(points[0].x(), v.x() + t.translation.x, 1e-6);
  EXPECT_NEAR(points[0].y(), v.y() + t.translation.y, 1e-6);
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
