// Unit tests of the laser line and point extractor on synthetic ray-cast scans.

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "rbpf_slam/core/features/laser_line_extractor.h"
#include "rbpf_slam/core/features/scan_matcher.h"

namespace rbpf_slam {
namespace core {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kInf = std::numeric_limits<double>::infinity();

/// A 2D world of wall segments and cylindrical posts, in the base frame.
struct World {
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> walls;
  std::vector<std::pair<Eigen::Vector2d, double>> posts;  // centre, radius
};

double castRay(const World& world, const Eigen::Vector2d& origin, double angle) {
  const Eigen::Vector2d d(std::cos(angle), std::sin(angle));
  double best = kInf;
  for (const auto& wall : world.walls) {
    const Eigen::Vector2d e = wall.second - wall.first;
    const double denom = d.x() * e.y() - d.y() * e.x();
    if (std::abs(denom) < 1e-12) continue;
    const Eigen::Vector2d w = wall.first - origin;
    const double t = (w.x() * e.y() - w.y() * e.x()) / denom;
    const double u = (w.x() * d.y() - w.y() * d.x()) / denom;
    if (t > 0.0 && u >= 0.0 && u <= 1.0) best = std::min(best, t);
  }
  for (const auto& post : world.posts) {
    const Eigen::Vector2d w = origin - post.first;
    const double b = w.dot(d), c = w.squaredNorm() - post.second * post.second;
    const double disc = b * b - c;
    if (disc < 0.0) continue;
    const double t = -b - std::sqrt(disc);
    if (t > 0.0) best = std::min(best, t);
  }
  return best;
}

/// Ray-casts a scan from a sensor mounted at sensor_pose on a base at the world origin.
RangeScan makeScan(const World& world, double angle_min, double increment, int count,
                   const Pose2& sensor_pose = Pose2::Zero(), double sigma = 0.0,
                   std::mt19937_64* rng = nullptr) {
  RangeScan scan;
  scan.angle_min = angle_min;
  scan.angle_increment = increment;
  scan.range_min = 0.05;
  scan.range_max = 30.0;
  scan.sensor_pose = sensor_pose;
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int i = 0; i < count; ++i) {
    double r = castRay(world, sensor_pose.head<2>(), sensor_pose.z() + angle_min + i * increment);
    if (std::isfinite(r) && sigma > 0.0) r += sigma * noise(*rng);
    scan.ranges.push_back(std::isfinite(r) && r <= scan.range_max
                              ? static_cast<float>(r)
                              : std::numeric_limits<float>::infinity());
  }
  return scan;
}

/// Two walls meeting at (3, 2): x = 3 (rho 3, theta 0) and y = 2 (rho 2, theta pi/2).
World roomCorner() {
  World world;
  world.walls.push_back({Eigen::Vector2d(3.0, -5.0), Eigen::Vector2d(3.0, 2.0)});
  world.walls.push_back({Eigen::Vector2d(3.0, 2.0), Eigen::Vector2d(-5.0, 2.0)});
  return world;
}

RangeScan roomScan(const Pose2& sensor_pose = Pose2::Zero()) {
  return makeScan(roomCorner(), -1.2, 0.5 * kDeg, 361, sensor_pose);
}

double angleDiff(double a, double b) { return std::abs(wrapAngle(a - b)); }

/// The line closest to (rho, theta), or null when none is within the tolerances.
const LineFeature* findLine(const std::vector<LineFeature>& lines, double rho, double theta,
                            double rho_tol, double theta_tol) {
  const LineFeature* best = nullptr;
  double best_score = kInf;
  for (const LineFeature& line : lines) {
    const double dr = std::abs(line.rho - rho), dt = angleDiff(line.theta, theta);
    if (dr > rho_tol || dt > theta_tol) continue;
    if (dr + dt < best_score) {
      best_score = dr + dt;
      best = &line;
    }
  }
  return best;
}

Eigen::Vector2d pointXY(const PointFeature& p) {
  return Eigen::Vector2d(p.range * std::cos(p.bearing), p.range * std::sin(p.bearing));
}

/// The point feature nearest to xy (base frame), or null when none is within tol.
const PointFeature* findPoint(const std::vector<PointFeature>& points, const Eigen::Vector2d& xy,
                              double tol) {
  const PointFeature* best = nullptr;
  double best_dist = tol;
  for (const PointFeature& p : points) {
    const double d = (pointXY(p) - xy).norm();
    if (d <= best_dist) {
      best_dist = d;
      best = &p;
    }
  }
  return best;
}

void expectRoomLines(const FeatureSet& f, double rho_tol, double theta_tol) {
  ASSERT_EQ(f.lines.size(), 2u);
  EXPECT_NE(findLine(f.lines, 3.0, 0.0, rho_tol, theta_tol), nullptr);
  EXPECT_NE(findLine(f.lines, 2.0, M_PI / 2, rho_tol, theta_tol), nullptr);
}

TEST(LaserLineExtractorTest, SingleWallRecovered) {
  const double rho = 2.5, theta = 0.3;
  const Eigen::Vector2d n(std::cos(theta), std::sin(theta)), t(-n.y(), n.x());
  World world;
  world.walls.push_back({rho * n - 10.0 * t, rho * n + 10.0 * t});
  const RangeScan scan = makeScan(world, -M_PI / 2, 0.5 * kDeg, 361);
  const FeatureSet f = LaserLineExtractor(LaserExtractorOptions()).extract(scan);
  ASSERT_EQ(f.lines.size(), 1u);
  const LineFeature& line = f.lines[0];
  EXPECT_NEAR(line.rho, rho, 0.01);
  EXPECT_LT(angleDiff(line.theta, theta), 0.5 * kDeg);
  EXPECT_GE(line.rho, 0.0);
  // Endpoints on the line and spanning most of the visible wall.
  EXPECT_NEAR(line.start.dot(n), rho, 1e-3);
  EXPECT_NEAR(line.end.dot(n), rho, 1e-3);
  EXPECT_GT((line.end - line.start).norm(), 10.0);
  EXPECT_GT(line.covariance(0, 0), 0.0);
  EXPECT_GT(line.covariance.determinant(), 0.0);
  EXPECT_TRUE(f.points.empty());
  EXPECT_EQ(f.stamp, scan.stamp);
}

TEST(LaserLineExtractorTest, RoomCornerGivesTwoLinesAndOneCorner) {
  const FeatureSet f = LaserLineExtractor(LaserExtractorOptions()).extract(roomScan());
  expectRoomLines(f, 0.01, 0.5 * kDeg);
  ASSERT_EQ(f.points.size(), 1u);
  const PointFeature& corner = f.points[0];
  EXPECT_LT((pointXY(corner) - Eigen::Vector2d(3.0, 2.0)).norm(), 0.05);
  EXPECT_EQ(corner.id, -1);
  const LaserExtractorOptions o;
  EXPECT_NEAR(corner.covariance(0, 0), o.sigma_point_range_m * o.sigma_point_range_m, 1e-12);
  EXPECT_NEAR(corner.covariance(1, 1), o.sigma_point_bearing_rad * o.sigma_point_bearing_rad,
              1e-12);
  EXPECT_NEAR(corner.covariance(0, 1), 0.0, 1e-12);
  // The line ends meet at the corner (the boundary pass returned stray points).
  for (const LineFeature& line : f.lines) {
    const double d = std::min((line.start - Eigen::Vector2d(3, 2)).norm(),
                              (line.end - Eigen::Vector2d(3, 2)).norm());
    EXPECT_LT(d, 0.05);
  }
}

TEST(LaserLineExtractorTest, InvalidBeamsAreSkipped) {
  LaserExtractorOptions options;
  options.max_range_m = 20.0;
  const LaserLineExtractor extractor(options);
  const RangeScan clean = roomScan();
  RangeScan dirty = clean;
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity(),
                       -std::numeric_limits<float>::infinity(),
                       0.0f,
                       -1.0f,
                       0.01f,   // below range_min
                       40.0f,   // above range_max
                       25.0f};  // above options.max_range_m
  int k = 0;
  for (size_t i = 5; i < dirty.ranges.size(); i += 13) dirty.ranges[i] = bad[k++ % 8];
  ASSERT_GE(k, 16);
  const FeatureSet a = extractor.extract(clean);
  const FeatureSet b = extractor.extract(dirty);
  expectRoomLines(b, 0.01, 0.5 * kDeg);
  ASSERT_EQ(a.lines.size(), b.lines.size());
  for (size_t i = 0; i < a.lines.size(); ++i) {
    EXPECT_NEAR(a.lines[i].rho, b.lines[i].rho, 1e-3);
    EXPECT_LT(angleDiff(a.lines[i].theta, b.lines[i].theta), 1e-3);
  }
  EXPECT_EQ(a.points.size(), b.points.size());
}

TEST(LaserLineExtractorTest, InvalidBeamsAreNeverFitted) {
  // A block of returns beyond range_max, an arc of radius 35 m: when those beams are
  // (wrongly) used they give extra lines, otherwise the wall behind is one line again.
  RangeScan scan = roomScan();
  for (size_t i = 100; i < 140; ++i) scan.ranges[i] = 35.0f;
  LaserExtractorOptions options;
  expectRoomLines(LaserLineExtractor(options).extract(scan), 0.01, 0.5 * kDeg);
  scan.range_max = 0.0;        // no bound from the scan...
  options.max_range_m = 34.0;  // ...but one from the options
  expectRoomLines(LaserLineExtractor(options).extract(scan), 0.01, 0.5 * kDeg);
  options.max_range_m = 0.0;  // no bound at all: the far returns are valid points
  EXPECT_GT(LaserLineExtractor(options).extract(scan).lines.size(), 2u);
}

TEST(LaserLineExtractorTest, ReadingsAtRangeMaxAreNoReturn) {
  // Drivers that do not send +inf for "no return" (REP 117) send range_max: an arc there is
  // not a wall (the scan matcher drops those beams too).
  RangeScan scan = roomScan();
  for (size_t i = 100; i < 140; ++i) scan.ranges[i] = static_cast<float>(scan.range_max);
  expectRoomLines(LaserLineExtractor(LaserExtractorOptions()).extract(scan), 0.01, 0.5 * kDeg);
}

TEST(LaserLineExtractorTest, NonPositiveRangeMaxMeansUnbounded) {
  RangeScan scan = roomScan();
  scan.range_max = 0.0;
  expectRoomLines(LaserLineExtractor(LaserExtractorOptions()).extract(scan), 0.01, 0.5 * kDeg);
  scan.range_max = std::numeric_limits<double>::quiet_NaN();
  expectRoomLines(LaserLineExtractor(LaserExtractorOptions()).extract(scan), 0.01, 0.5 * kDeg);
  // An options bound below every return leaves nothing.
  LaserExtractorOptions options;
  options.max_range_m = 1.0;
  EXPECT_TRUE(LaserLineExtractor(options).extract(scan).lines.empty());
}

TEST(LaserLineExtractorTest, ReversedScanGivesSameLines) {
  const LaserLineExtractor extractor{LaserExtractorOptions()};
  const RangeScan forward = roomScan();
  const double last = forward.angle_min + 360 * forward.angle_increment;
  const RangeScan reversed = makeScan(roomCorner(), last, -0.5 * kDeg, 361);
  const FeatureSet a = extractor.extract(forward);
  const FeatureSet b = extractor.extract(reversed);
  expectRoomLines(b, 0.01, 0.5 * kDeg);
  ASSERT_EQ(a.lines.size(), b.lines.size());
  for (const LineFeature& line : a.lines) {
    const LineFeature* match = findLine(b.lines, line.rho, line.theta, 1e-4, 1e-4);
    ASSERT_NE(match, nullptr);
    // Same segment, walked the other way.
    EXPECT_LT((match->start - line.end).norm(), 1e-4);
    EXPECT_LT((match->end - line.start).norm(), 1e-4);
  }
  ASSERT_EQ(b.points.size(), 1u);
  EXPECT_LT((pointXY(b.points[0]) - Eigen::Vector2d(3.0, 2.0)).norm(), 0.05);
}

TEST(LaserLineExtractorTest, EmptyAndInvalidScansGiveNoFeatures) {
  const LaserLineExtractor extractor{LaserExtractorOptions()};
  RangeScan empty;
  empty.angle_increment = 0.01;
  empty.range_max = 10.0;
  EXPECT_TRUE(extractor.extract(empty).empty());

  RangeScan invalid = roomScan();
  const float bad[] = {std::numeric_limits<float>::quiet_NaN(),
                       std::numeric_limits<float>::infinity(),
                       0.0f,
                       -2.0f,
                       0.01f,
                       50.0f};
  for (size_t i = 0; i < invalid.ranges.size(); ++i) invalid.ranges[i] = bad[i % 6];
  EXPECT_TRUE(extractor.extract(invalid).empty());

  RangeScan bad_angles = roomScan();
  bad_angles.angle_increment = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(extractor.extract(bad_angles).empty());

  RangeScan single = roomScan();
  single.ranges.resize(1);
  EXPECT_TRUE(extractor.extract(single).lines.empty());
}

// Beams that all hit one spot (a zero angle increment) once fitted as a line of arbitrary
// direction with a covariance of 1e10 (the raw sums' rounding residue read as spread).
TEST(LaserLineExtractorTest, PointsAtOneSpotGiveNoLine) {
  LaserExtractorOptions options;
  options.min_line_length_m = 0.0;
  for (const std::string method : {"incremental", "split_and_merge"}) {
    options.method = method;
    const LaserLineExtractor extractor{options};
    RangeScan scan;
    scan.angle_min = 0.7;
    scan.angle_increment = 0.0;
    scan.range_max = 10.0;
    scan.ranges.assign(20, 3.3f);
    EXPECT_TRUE(extractor.extract(scan).lines.empty()) << method;
  }
  LineMoments same;
  for (int i = 0; i < 20; ++i) same.add(Eigen::Vector2d(3.3 * std::cos(0.7), 3.3 * std::sin(0.7)));
  Eigen::Vector2d normal;
  double offset = 0.0;
  EXPECT_FALSE(same.normal(&normal, &offset));
}

// wrapAngle promises [-pi, pi): an angle just below -pi rounded up to +pi.
TEST(LaserLineExtractorTest, WrapAngleNeverReturnsPlusPi) {
  for (const double a : {std::nextafter(-M_PI, -10.0), -M_PI, M_PI, 3.0 * M_PI,
                         std::nextafter(M_PI, 10.0), -3.0 * M_PI}) {
    const double w = wrapAngle(a);
    EXPECT_GE(w, -M_PI) << a;
    EXPECT_LT(w, M_PI) << a;
  }
  double rho = 2.0, theta = std::nextafter(-M_PI, -10.0);
  normalizeLine(rho, theta);
  EXPECT_LT(theta, M_PI);
}

// A mount a world away is a broken transform: no points for the matcher (its grid indices
// overflowed), as the line extractor already refused.
TEST(LaserLineExtractorTest, AnAbsurdMountGivesNoPoints) {
  RangeScan scan = roomScan();
  ASSERT_FALSE(scanPointsInBase(scan, 30.0).empty());
  scan.sensor_pose = Pose2(1e300, 0.0, 0.0);
  EXPECT_TRUE(scanPointsInBase(scan, 30.0).empty());
  EXPECT_TRUE(LaserLineExtractor{LaserExtractorOptions()}.extract(scan).empty());
}

TEST(LaserLineExtractorTest, SensorPoseGivesBaseFrameFeatures) {
  const Pose2 mount(0.2, 0.0, 0.1);
  const FeatureSet f = LaserLineExtractor(LaserExtractorOptions()).extract(roomScan(mount));
  // The walls are x = 3 and y = 2 in the base frame, whatever the mounting.
  expectRoomLines(f, 0.01, 0.5 * kDeg);
  ASSERT_EQ(f.points.size(), 1u);
  EXPECT_LT((pointXY(f.points[0]) - Eigen::Vector2d(3.0, 2.0)).norm(), 0.05);
  for (const LineFeature& line : f.lines) {
    const Eigen::Vector2d n(std::cos(line.theta), std::sin(line.theta));
    EXPECT_NEAR(line.start.dot(n), line.rho, 1e-6);
    EXPECT_NEAR(line.end.dot(n), line.rho, 1e-6);
  }
  // A sensor facing backwards behind the wall x = 3 sees it at rho_s = 1, theta_s = 0:
  // rho_b = 1 + 4 cos(pi) < 0 must flip to (3, 0).
  World wall;
  wall.walls.push_back({Eigen::Vector2d(3.0, -3.0), Eigen::Vector2d(3.0, 3.0)});
  const FeatureSet g = LaserLineExtractor(LaserExtractorOptions())
                           .extract(makeScan(wall, -1.2, 0.5 * kDeg, 361, Pose2(4.0, 0.0, M_PI)));
  ASSERT_EQ(g.lines.size(), 1u);
  EXPECT_NEAR(g.lines[0].rho, 3.0, 0.01);
  EXPECT_LT(angleDiff(g.lines[0].theta, 0.0), 0.5 * kDeg);
}

TEST(LaserLineExtractorTest, TransformLineFeatureMatchesFiniteDifferences) {
  const Pose2 pose(0.4, -0.7, 2.5);
  LineFeature line;
  line.rho = 1.3;
  line.theta = 0.4;
  line.covariance << 4e-4, 1e-4, 1e-4, 2e-4;
  const LineFeature out = transformLineFeature(pose, line);
  // Direct computation, then the flip that keeps rho >= 0.
  double theta_b = line.theta + pose.z();
  double rho_b = line.rho + pose.x() * std::cos(theta_b) + pose.y() * std::sin(theta_b);
  normalizeLine(rho_b, theta_b);
  EXPECT_NEAR(out.rho, rho_b, 1e-12);
  EXPECT_NEAR(out.theta, theta_b, 1e-12);
  Eigen::Matrix2d jacobian;
  const double h = 1e-6;
  for (int j = 0; j < 2; ++j) {
    LineFeature plus = line, minus = line;
    (j == 0 ? plus.rho : plus.theta) += h;
    (j == 0 ? minus.rho : minus.theta) -= h;
    const LineFeature a = transformLineFeature(pose, plus), b = transformLineFeature(pose, minus);
    jacobian(0, j) = (a.rho - b.rho) / (2 * h);
    jacobian(1, j) = wrapAngle(a.theta - b.theta) / (2 * h);
  }
  const Eigen::Matrix2d expected = jacobian * line.covariance * jacobian.transpose();
  EXPECT_LT((out.covariance - expected).norm(), 1e-9);
}

TEST(LaserLineExtractorTest, TransformPointFeatureMatchesFiniteDifferences) {
  const Pose2 pose(0.2, 0.1, -0.6);
  PointFeature p;
  p.range = 2.0;
  p.bearing = 0.9;
  p.covariance << 0.0025, 0.0, 0.0, 0.0004;
  const PointFeature out = transformPointFeature(pose, p);
  const Eigen::Vector2d xy =
      transformPoint(pose, Eigen::Vector2d(2.0 * std::cos(0.9), 2.0 * std::sin(0.9)));
  EXPECT_NEAR(out.range, xy.norm(), 1e-12);
  EXPECT_NEAR(out.bearing, std::atan2(xy.y(), xy.x()), 1e-12);
  Eigen::Matrix2d jacobian;
  const double h = 1e-6;
  for (int j = 0; j < 2; ++j) {
    PointFeature plus = p, minus = p;
    (j == 0 ? plus.range : plus.bearing) += h;
    (j == 0 ? minus.range : minus.bearing) -= h;
    const PointFeature a = transformPointFeature(pose, plus);
    const PointFeature b = transformPointFeature(pose, minus);
    jacobian(0, j) = (a.range - b.range) / (2 * h);
    jacobian(1, j) = wrapAngle(a.bearing - b.bearing) / (2 * h);
  }
  EXPECT_LT((out.covariance - jacobian * p.covariance * jacobian.transpose()).norm(), 1e-9);
}

TEST(LaserLineExtractorTest, SplitAndMergeRecoversSameWalls) {
  LaserExtractorOptions options;
  options.method = "split_and_merge";
  const FeatureSet f = LaserLineExtractor(options).extract(roomScan());
  expectRoomLines(f, 0.01, 0.5 * kDeg);
  ASSERT_EQ(f.points.size(), 1u);
  EXPECT_LT((pointXY(f.points[0]) - Eigen::Vector2d(3.0, 2.0)).norm(), 0.05);
  // A three-wall room, so that the recursion must split more than once.
  World world = roomCorner();
  world.walls.push_back({Eigen::Vector2d(-2.0, -3.0), Eigen::Vector2d(3.0, -3.0)});
  world.walls[0].first = Eigen::Vector2d(3.0, -3.0);
  const FeatureSet g = LaserLineExtractor(options).extract(makeScan(world, -M_PI, kDeg, 360));
  ASSERT_EQ(g.lines.size(), 3u);
  EXPECT_NE(findLine(g.lines, 3.0, -M_PI / 2, 0.01, 0.5 * kDeg), nullptr);
  EXPECT_EQ(g.points.size(), 2u);
}

TEST(LaserLineExtractorTest, PostGivesPointFeature) {
  World world = roomCorner();
  const Eigen::Vector2d centre(1.5, 0.3);
  world.posts.push_back({centre, 0.06});
  for (const std::string method : {"incremental", "split_and_merge"}) {
    LaserExtractorOptions options;
    options.method = method;
    const FeatureSet g =
        LaserLineExtractor(options).extract(makeScan(world, -1.2, 0.5 * kDeg, 361));
    expectRoomLines(g, 0.01, 0.5 * kDeg);  // the wall behind the post is still one line
    ASSERT_EQ(g.points.size(), 2u) << method;
    const PointFeature* post = findPoint(g.points, centre, 0.03);
    ASSERT_NE(post, nullptr) << method;
    EXPECT_EQ(post->id, -1);
    EXPECT_NE(findPoint(g.points, Eigen::Vector2d(3.0, 2.0), 0.05), nullptr);
  }
  // Without cluster extraction the post is not reported.
  LaserExtractorOptions no_clusters;
  no_clusters.extract_clusters = false;
  const FeatureSet h =
      LaserLineExtractor(no_clusters).extract(makeScan(world, -1.2, 0.5 * kDeg, 361));
  EXPECT_EQ(findPoint(h.points, centre, 0.1), nullptr);
}

TEST(LaserLineExtractorTest, PostAgainstOpenSpaceAndWidePostsRejected) {
  World world;
  world.posts.push_back({Eigen::Vector2d(2.0, 0.0), 0.08});  // nothing behind: invalid sides
  world.posts.push_back({Eigen::Vector2d(2.0, 2.0), 0.5});   // too wide to be a post
  const FeatureSet f =
      LaserLineExtractor(LaserExtractorOptions()).extract(makeScan(world, -1.2, 0.5 * kDeg, 361));
  ASSERT_EQ(f.points.size(), 1u);
  EXPECT_LT((pointXY(f.points[0]) - Eigen::Vector2d(2.0, 0.0)).norm(), 0.03);
}

TEST(FitLineTest, ExactLinesInNormalForm) {
  // Lines whose normals point into every quadrant, including theta = -pi.
  for (const double theta : {0.2, 1.9, -2.5, -1.0, -M_PI}) {
    const double rho = 1.7;
    const Eigen::Vector2d n(std::cos(theta), std::sin(theta)), t(-n.y(), n.x());
    std::vector<Eigen::Vector2d> pts;
    for (int i = 0; i < 10; ++i) pts.push_back(rho * n + (0.3 * i - 1.0) * t);
    LineFeature line;
    ASSERT_TRUE(fitLine(pts, 0.01, &line));
    EXPECT_NEAR(line.rho, rho, 1e-9);
    EXPECT_LT(angleDiff(line.theta, theta), 1e-9);
    EXPECT_GE(line.theta, -M_PI);
    EXPECT_LT(line.theta, M_PI);
    EXPECT_LT((line.start - pts.front()).norm(), 1e-9);
    EXPECT_LT((line.end - pts.back()).norm(), 1e-9);
  }
  LineFeature line;
  EXPECT_FALSE(fitLine({Eigen::Vector2d(1, 2)}, 0.01, &line));
  EXPECT_FALSE(fitLine({Eigen::Vector2d(1, 2), Eigen::Vector2d(1, 2)}, 0.01, &line));
  // Far from the origin the fit keeps its precision.
  std::vector<Eigen::Vector2d> far;
  for (int i = 0; i < 20; ++i) far.push_back(Eigen::Vector2d(1e5 + 0.1 * i, 2e5));
  ASSERT_TRUE(fitLine(far, 0.01, &line));
  EXPECT_NEAR(line.rho, 2e5, 1e-6);
  EXPECT_LT(angleDiff(line.theta, M_PI / 2), 1e-9);
}

TEST(FitLineTest, CovarianceMatchesMonteCarlo) {
  const double rho = 2.0, theta = 0.7, sigma = 0.01;
  const Eigen::Vector2d n(std::cos(theta), std::sin(theta)), t(-n.y(), n.x());
  std::vector<Eigen::Vector2d> truth;
  for (int i = 0; i < 20; ++i) truth.push_back(rho * n + (1.0 + 0.1 * i) * t);  // off-centre
  LineFeature predicted;
  ASSERT_TRUE(fitLine(truth, sigma, &predicted));
  ASSERT_GT(std::abs(predicted.covariance(0, 1)) /
                std::sqrt(predicted.covariance(0, 0) * predicted.covariance(1, 1)),
            0.5);  // strongly correlated, so the sign is really tested

  std::mt19937_64 rng(42);
  std::normal_distribution<double> noise(0.0, sigma);
  const int trials = 20000;
  Eigen::Matrix2d sum = Eigen::Matrix2d::Zero();
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  std::vector<Eigen::Vector2d> samples;
  std::vector<Eigen::Vector2d> pts(truth.size());
  for (int k = 0; k < trials; ++k) {
    for (size_t i = 0; i < truth.size(); ++i) {
      pts[i] = truth[i] + Eigen::Vector2d(noise(rng), noise(rng));
    }
    LineFeature line;
    ASSERT_TRUE(fitLine(pts, sigma, &line));
    const Eigen::Vector2d e(line.rho - rho, wrapAngle(line.theta - theta));
    samples.push_back(e);
    mean += e;
  }
  mean /= trials;
  for (const Eigen::Vector2d& e : samples) sum += (e - mean) * (e - mean).transpose();
  const Eigen::Matrix2d empirical = sum / (trials - 1);
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 2; ++c) {
      const double scale = std::sqrt(predicted.covariance(r, r) * predicted.covariance(c, c));
      EXPECT_LT(std::abs(empirical(r, c) - predicted.covariance(r, c)),
                0.2 * std::abs(predicted.covariance(r, c)) + 0.02 * scale)
          << "element (" << r << ", " << c << "): empirical " << empirical(r, c) << " predicted "
          << predicted.covariance(r, c);
    }
  }
}

TEST(FitLineTest, MomentsAddRemoveMatchFitLine) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.02);
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < 30; ++i)
    pts.push_back(Eigen::Vector2d(0.1 * i, 1.0 + 0.5 * 0.1 * i + noise(rng)));
  LineMoments m;
  for (const auto& p : pts) m.add(p);
  m.add(Eigen::Vector2d(50.0, -20.0));  // an outlier, then removed again
  m.remove(Eigen::Vector2d(50.0, -20.0));
  LineFeature a, b;
  ASSERT_TRUE(m.fit(0.02, &a));
  ASSERT_TRUE(fitLine(pts, 0.02, &b));
  EXPECT_NEAR(a.rho, b.rho, 1e-9);
  EXPECT_NEAR(a.theta, b.theta, 1e-9);
  EXPECT_LT((a.covariance - b.covariance).norm(), 1e-12);
  EXPECT_GT(m.meanSquaredResidual(), 0.0);
  EXPECT_LT(m.meanSquaredResidual(), 4 * 0.02 * 0.02);
}

TEST(LaserLineExtractorTest, ValidateRejectsBadValues) {
  EXPECT_NO_THROW(validate(LaserExtractorOptions()));
  auto expectRejected = [](const LaserExtractorOptions& o, const std::string& needle) {
    try {
      validate(o);
      ADD_FAILURE() << "accepted, expected rejection naming " << needle;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
    EXPECT_THROW(LaserLineExtractor{o}, std::invalid_argument);
  };
  LaserExtractorOptions o;
  o.method = "hough";
  expectRejected(o, "laser_features.method = 'hough'");
  o = LaserExtractorOptions();
  o.method = "hough";
  expectRejected(o, "split_and_merge");
  o = LaserExtractorOptions();
  o.sigma_range_m = -1.0;
  expectRejected(o, "laser_features.sigma_range_m = -1 is out of range");
  o = LaserExtractorOptions();
  o.max_mean_sq_residual_m2 = std::numeric_limits<double>::quiet_NaN();
  expectRejected(o, "laser_features.max_mean_sq_residual_m2 = nan");
  o = LaserExtractorOptions();
  o.min_points_per_line = 1;
  expectRejected(o, "laser_features.min_points_per_line = 1 is out of range [2,");
  o = LaserExtractorOptions();
  o.split_distance_m = 0.0;
  expectRejected(o, "split_distance_m");
  o = LaserExtractorOptions();
  o.max_point_gap_m = kInf;
  expectRejected(o, "max_point_gap_m");
  o = LaserExtractorOptions();
  o.corner_min_angle_rad = 2.0;
  expectRejected(o, "corner_min_angle_rad");
  o = LaserExtractorOptions();
  o.cluster_min_points = 0;
  expectRejected(o, "cluster_min_points");
  o = LaserExtractorOptions();
  o.sigma_point_bearing_rad = 0.0;
  expectRejected(o, "sigma_point_bearing_rad");
  o = LaserExtractorOptions();
  o.max_range_m = -5.0;
  expectRejected(o, "laser_features.max_range_m = -5 is out of range [0, 1e+06]");
}

TEST(LaserLineExtractorTest, NoisyScanRecoversWalls) {
  for (const std::string method : {"incremental", "split_and_merge"}) {
    LaserExtractorOptions options;
    options.method = method;
    const LaserLineExtractor extractor(options);
    for (uint64_t seed = 1; seed <= 10; ++seed) {
      std::mt19937_64 rng(seed);
      const RangeScan scan =
          makeScan(roomCorner(), -1.2, 0.5 * kDeg, 361, Pose2(0.1, -0.2, 0.3), 0.01, &rng);
      const FeatureSet f = extractor.extract(scan);
      SCOPED_TRACE(method + " seed " + std::to_string(seed));
      expectRoomLines(f, 0.02, 1.0 * kDeg);
      ASSERT_EQ(f.points.size(), 1u);
      EXPECT_LT((pointXY(f.points[0]) - Eigen::Vector2d(3.0, 2.0)).norm(), 0.05);
    }
  }
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam
