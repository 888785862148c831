// AnchoredFilter: a filter run in coordinates centred on the run's start gives the same
// results wherever the odometry frame begins, and reports them in the map frame.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "rbpf_slam/core/filters/anchored_filter.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/grid/grid_map_data.h"
#include "rbpf_slam/core/slam/slam_session.h"
#include "synthetic_world.h"

namespace rbpf_slam {
namespace core {
namespace {

LandmarkEstimate line(double rho, double theta) {
  LandmarkEstimate l;
  l.type = LandmarkType::kLine;
  l.mean = Eigen::Vector2d(rho, theta);
  l.covariance << 0.04, 0.003, 0.003, 0.01;
  l.start = Eigen::Vector2d(1, 2);
  l.end = Eigen::Vector2d(3, -1);
  return l;
}

TEST(ShiftLandmark, MovesPointsAndLinesAndComesBack) {
  LandmarkEstimate point;
  point.mean = Eigen::Vector2d(2, 3);
  const Eigen::Vector2d shift(100.0, -40.0);
  EXPECT_TRUE(shiftLandmark(point, shift).mean.isApprox(Eigen::Vector2d(102, -37)));
  EXPECT_TRUE(shiftLandmark(point, shift).covariance.isApprox(point.covariance));

  // The line x = 2 (rho 2, theta 0) is x = 102 after the shift; shifted by (-5, 0) it is
  // x = -3, whose normal form is rho 3, theta -pi.
  const LandmarkEstimate wall = line(2.0, 0.0);
  const LandmarkEstimate moved = shiftLandmark(wall, shift);
  EXPECT_NEAR(moved.mean.x(), 102.0, 1e-12);
  EXPECT_NEAR(moved.mean.y(), 0.0, 1e-12);
  EXPECT_TRUE(moved.start.isApprox(Eigen::Vector2d(101, -38)));
  const LandmarkEstimate flipped = shiftLandmark(wall, Eigen::Vector2d(-5.0, 0.0));
  EXPECT_NEAR(flipped.mean.x(), 3.0, 1e-12);
  EXPECT_NEAR(std::fabs(flipped.mean.y()), M_PI, 1e-12);

  for (const LandmarkEstimate& l : {line(2.0, 0.7), line(0.5, -2.9), line(7.0, 2.0)}) {
    for (const Eigen::Vector2d& s : {shift, Eigen::Vector2d(-30, 12), Eigen::Vector2d(-8, -3)}) {
      const LandmarkEstimate back = shiftLandmark(shiftLandmark(l, s), -s);
      EXPECT_NEAR(back.mean.x(), l.mean.x(), 1e-9);
      EXPECT_NEAR(wrapAngle(back.mean.y() - l.mean.y()), 0.0, 1e-12);
      EXPECT_TRUE(back.covariance.isApprox(l.covariance, 1e-9)) << back.covariance;
    }
  }
}

// The covariance follows the shift's Jacobian, checked against finite differences (also
// across the normal form's flip).
TEST(ShiftLandmark, LineCovarianceFollowsTheJacobian) {
  for (const Eigen::Vector2d& s : {Eigen::Vector2d(100, -40), Eigen::Vector2d(-5, 0.3)}) {
    const LandmarkEstimate l = line(2.0, 0.2);
    const auto moved = [&](double rho, double theta) {
      return shiftLandmark(line(rho, theta), s).mean;
    };
    const double h = 1e-6;
    Eigen::Matrix2d numeric;
    numeric.col(0) = (moved(2.0 + h, 0.2) - moved(2.0 - h, 0.2)) / (2 * h);
    numeric.col(1) = (moved(2.0, 0.2 + h) - moved(2.0, 0.2 - h)) / (2 * h);
    const Eigen::Matrix2d expected = numeric * l.covariance * numeric.transpose();
    EXPECT_TRUE(shiftLandmark(l, s).covariance.isApprox(expected, 1e-6))
        << shiftLandmark(l, s).covariance << "\nexpected\n" << expected;
  }
}

struct RunResult {
  std::vector<TrajectoryPoint> path;
  std::vector<LandmarkEstimate> landmarks;
  std::vector<WeightedPose> particles;
  std::vector<std::vector<Pose2>> member_paths;
  bool has_grid = false;  // grid variants: where cell (0, 0)'s corner is
  Eigen::Vector2d grid_origin = Eigen::Vector2d::Zero();
};

/// A loop around SyntheticWorld with the odometry frame's origin at -offset (the robot starts
/// at offset in it), the filter variant given, its origin as filter_origin says.
RunResult runShifted(const FilterOptions& filter, const std::string& filter_origin,
               const Eigen::Vector2d& offset) {
  SessionOptions options;
  options.filter_origin = filter_origin;
  SlamSession session(createFilter(filter), options);
  SyntheticWorld world;
  Rng rng(7);
  Pose2 truth(0.0, -2.8, 0.0);
  const Pose2 odom_origin(offset.x(), offset.y(), 0.3);  // the start, in the odometry frame
  Pose2 odom = odom_origin;
  for (int k = 0; k < 60; ++k) {
    const Pose2 step(0.25, 0.0, k % 15 == 14 ? M_PI / 2 : 0.02);
    if (k > 0) {
      truth = compose(truth, step);
      odom = compose(odom, Pose2(step.x() * 1.03, 0.0, step.z() * 1.02));
    }
    session.process(1.0 + k, odom, world.observe(truth, rng, 0.02, 0.01));
  }
  RunResult run;
  run.path = session.estimatedTrajectory();
  run.landmarks = session.filter().landmarks();
  run.particles = session.filter().particles();
  for (int m = 0; m < session.filter().members(); ++m) {
    run.member_paths.push_back(session.filter().member(m).bestPath());
  }
  GridMapData grid;
  if (session.filter().occupancyGrid(grid)) {
    run.has_grid = true;
    run.grid_origin = Eigen::Vector2d(grid.origin_x_m, grid.origin_y_m);
  }
  return run;
}

/// The largest difference between two runs' poses, landmarks and particles once b is moved
/// back by shift; infinity when they differ in size.
double largestDifference(const RunResult& a, const RunResult& b, const Eigen::Vector2d& shift) {
  const double inf = std::numeric_limits<double>::infinity();
  if (a.path.size() != b.path.size() || a.landmarks.size() != b.landmarks.size() ||
      a.particles.size() != b.particles.size() || a.member_paths.size() != b.member_paths.size()) {
    return inf;
  }
  if (a.has_grid != b.has_grid) return inf;
  double worst = a.has_grid ? (a.grid_origin + shift - b.grid_origin).norm() : 0.0;
  const auto pose = [&](const Pose2& p, const Pose2& q) {
    worst = std::max(worst, (p.head<2>() + shift - q.head<2>()).norm());
    worst = std::max(worst, std::fabs(wrapAngle(p.z() - q.z())));
  };
  for (size_t i = 0; i < a.path.size(); ++i) pose(a.path[i].pose, b.path[i].pose);
  for (size_t i = 0; i < a.particles.size(); ++i) pose(a.particles[i].pose, b.particles[i].pose);
  for (size_t m = 0; m < a.member_paths.size(); ++m) {
    if (a.member_paths[m].size() != b.member_paths[m].size()) return inf;
    for (size_t i = 0; i < a.member_paths[m].size(); ++i) {
      pose(a.member_paths[m][i], b.member_paths[m][i]);
    }
  }
  for (size_t i = 0; i < a.landmarks.size(); ++i) {
    const LandmarkEstimate moved = shiftLandmark(a.landmarks[i], shift);
    worst = std::max(worst, (moved.mean - b.landmarks[i].mean).norm());
    worst = std::max(worst, (moved.covariance - b.landmarks[i].covariance).norm());
  }
  return worst;
}

FilterOptions optionsFor(const std::string& variant) {
  FilterOptions filter;
  filter.variant = variant;
  filter.particles = variant == "multifilter_smc" ? 200 : 30;
  filter.seed = 5;
  return filter;
}

// With filter_origin "start", the same run with the odometry frame's origin 175 m away gives
// the same path, particles and map, moved by the offset: the filter sees the same numbers.
TEST(AnchoredFilter, ResultsDoNotDependOnWhereTheOdometryFrameBegins) {
  const Eigen::Vector2d offset(150.0, -90.0);
  std::vector<FilterOptions> cases;
  for (const char* v : {"fastslam2", "robust_fastslam2", "hinf_fastslam", "multifilter_smc",
                        "ekf_slam", "dpf", "grid_pf"}) {
    cases.push_back(optionsFor(v));
  }
  cases.push_back(optionsFor("fastslam2"));
  cases.back().ensemble.members = 3;  // members are reported through views
  for (const FilterOptions& filter : cases) {
    const std::string name = filter.variant + (filter.ensemble.members > 1 ? " ensemble" : "");
    const RunResult near = runShifted(filter, "start", Eigen::Vector2d::Zero());
    const RunResult far = runShifted(filter, "start", offset);
    ASSERT_EQ(near.path.size(), 60u) << name;
    if (filter.variant != "dpf" && filter.variant != "grid_pf") {  // no landmark map
      EXPECT_FALSE(near.landmarks.empty()) << name;
    }
    EXPECT_LT(largestDifference(near, far, offset), 1e-6) << name;
    EXPECT_EQ(far.member_paths.size(), static_cast<size_t>(filter.ensemble.members)) << name;
    EXPECT_EQ(far.has_grid, filter.variant == "grid_pf") << name;
  }
}

// What the anchoring removes: with the filter's origin at the odometry frame's, the line
// filters' association depends on the offset, and the same run ends differently.
TEST(AnchoredFilter, WithoutItTheLineFiltersDependOnTheOffset) {
  const Eigen::Vector2d offset(150.0, -90.0);
  int differing = 0;
  for (const char* v : {"fastslam2", "multifilter_smc", "ekf_slam"}) {
    const RunResult near = runShifted(optionsFor(v), "odom", Eigen::Vector2d::Zero());
    const RunResult far = runShifted(optionsFor(v), "odom", offset);
    if (largestDifference(near, far, offset) > 1e-3) ++differing;
  }
  EXPECT_GE(differing, 1);
}

TEST(AnchoredFilter, GivenPosesAndMapsAreInTheMapFrame) {
  FilterOptions filter = optionsFor("fastslam2");
  AnchoredFilter anchored(createFilter(filter));
  anchored.reset(Pose2(50.0, 20.0, 0.4));
  EXPECT_TRUE(anchored.origin().isApprox(Eigen::Vector2d(50, 20)));
  EXPECT_TRUE(anchored.estimate().mean.isApprox(Pose2(50.0, 20.0, 0.4)));
  EXPECT_TRUE(anchored.inner().estimate().mean.isApprox(Pose2(0.0, 0.0, 0.4)));
  LandmarkEstimate post;
  post.mean = Eigen::Vector2d(55.0, 21.0);
  post.covariance = Eigen::Matrix2d::Identity() * 0.01;
  ASSERT_TRUE(anchored.loadMap({post, line(60.0, 0.1)}));
  const std::vector<LandmarkEstimate> map = anchored.landmarks();
  ASSERT_EQ(map.size(), 2u);
  EXPECT_TRUE(map[0].mean.isApprox(post.mean, 1e-9));
  EXPECT_TRUE(map[1].mean.isApprox(Eigen::Vector2d(60.0, 0.1), 1e-9)) << map[1].mean;
  ASSERT_TRUE(anchored.resetPose(Pose2(52.0, 18.0, -0.2), Eigen::Matrix3d::Identity() * 1e-8));
  EXPECT_TRUE(anchored.estimate().mean.isApprox(Pose2(52.0, 18.0, -0.2), 1e-3))
      << anchored.estimate().mean.transpose();
  EXPECT_TRUE(anchored.inner().estimate().mean.isApprox(Pose2(2.0, -2.0, -0.2), 1e-3));
}

// Through a session: a prior map given before the first frame (loaded at the origin, then
// again once the first frame moves the filter's origin to the start) stays where it was, and
// a start pose puts the robot there.
TEST(AnchoredFilter, APriorMapAndAStartPoseSurviveTheFirstFrameFarFromTheOrigin) {
  SessionOptions options;
  SlamSession session(createFilter(optionsFor("fastslam2")), options);
  LandmarkEstimate post;
  post.id = 4;
  post.mean = Eigen::Vector2d(205.0, -48.0);
  post.covariance = Eigen::Matrix2d::Identity() * 1e-4;
  ASSERT_TRUE(session.setPriorMap({post, line(210.0, 0.2)}));
  ASSERT_TRUE(session.setPose(Pose2(203.0, -50.0, 0.1), Eigen::Matrix3d::Identity() * 1e-6));
  ASSERT_EQ(session.process(1.0, Pose2(-40.0, 70.0, 0.5), FeatureSet()),
            FrameResult::kFirstFrame);
  const auto* anchored = dynamic_cast<const AnchoredFilter*>(&session.filter());
  ASSERT_NE(anchored, nullptr);
  EXPECT_TRUE(anchored->origin().isApprox(Eigen::Vector2d(203.0, -50.0)));
  EXPECT_TRUE(session.filter().estimate().mean.isApprox(Pose2(203.0, -50.0, 0.1), 1e-2));
  const std::vector<LandmarkEstimate> map = session.filter().landmarks();
  ASSERT_EQ(map.size(), 2u);
  EXPECT_TRUE(map[0].mean.isApprox(post.mean, 1e-9)) << map[0].mean.transpose();
  EXPECT_TRUE(map[1].mean.isApprox(Eigen::Vector2d(210.0, 0.2), 1e-9)) << map[1].mean.transpose();
  // The odometry's own frame: map -> odom puts odometry (-40, 70) at the start pose.
  EXPECT_TRUE(compose(session.mapToOdom(), Pose2(-40.0, 70.0, 0.5))
                  .isApprox(session.filter().estimate().mean, 1e-9));
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam
