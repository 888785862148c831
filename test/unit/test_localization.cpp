// Map reuse: landmark files (round trip, errors, occupancy picture), FastSLAM 2.0 started
// from a saved map in localization-only mode, and the session's initial pose.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/slam/slam_session.h"
#include "rbpf_slam/io/landmark_file.h"

namespace rbpf_slam {
namespace {

using core::LandmarkEstimate;
using core::LandmarkType;
using core::Pose2;

std::string tempPath(const std::string& name) {
  return ::testing::TempDir() + "rbpf_localization_" + name;
}

/// Four posts at known places, as a saved map.
std::vector<LandmarkEstimate> postMap() {
  std::vector<LandmarkEstimate> map;
  const double xy[4][2] = {{3, 1}, {4, -2}, {6, 2}, {1, 3}};
  for (int i = 0; i < 4; ++i) {
    LandmarkEstimate l;
    l.id = 10 + i;
    l.mean = Eigen::Vector2d(xy[i][0], xy[i][1]);
    l.covariance = Eigen::Matrix2d::Identity() * 1e-4;
    l.start = l.end = l.mean;
    l.observations = 20;
    map.push_back(l);
  }
  return map;
}

/// Range-bearing observations of map's posts from pose, noise-free.
core::FeatureSet observe(const std::vector<LandmarkEstimate>& map, const Pose2& pose) {
  core::FeatureSet features;
  for (const auto& l : map) {
    const Eigen::Vector2d d = l.mean - pose.head<2>();
    core::PointFeature f;
    f.range = d.norm();
    f.bearing = core::wrapAngle(std::atan2(d.y(), d.x()) - pose.z());
    f.covariance = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
    features.points.push_back(f);
  }
  return features;
}

TEST(LandmarkFile, RoundTripKeepsPointsAndLines) {
  std::vector<LandmarkEstimate> map = postMap();
  LandmarkEstimate wall;
  wall.id = 3;
  wall.type = LandmarkType::kLine;
  wall.mean = Eigen::Vector2d(2.5, 0.3);
  wall.covariance << 0.01, 0.001, 0.001, 0.002;
  wall.start = Eigen::Vector2d(1.0, 2.0);
  wall.end = Eigen::Vector2d(3.0, 1.5);
  wall.observations = 7;
  map.push_back(wall);
  const std::string path = tempPath("roundtrip.yaml");
  io::writeLandmarksYaml(path, map);
  const std::vector<LandmarkEstimate> back = io::loadLandmarksYaml(path);
  ASSERT_EQ(back.size(), map.size());
  for (size_t i = 0; i < map.size(); ++i) {
    EXPECT_EQ(back[i].id, map[i].id);
    EXPECT_EQ(back[i].type, map[i].type);
    EXPECT_TRUE(back[i].mean.isApprox(map[i].mean, 1e-8));
    EXPECT_TRUE(back[i].covariance.isApprox(map[i].covariance, 1e-8));
    EXPECT_TRUE(back[i].start.isApprox(map[i].start, 1e-8));
    EXPECT_TRUE(back[i].end.isApprox(map[i].end, 1e-8));
    EXPECT_EQ(back[i].observations, map[i].observations);
  }
}

// A line written with rho < 0 is read in normal form (rho >= 0, theta turned by pi, the
// covariance's correlation negated): the same line, as the filters keep their lines.
TEST(LandmarkFile, ALineWithNegativeRhoIsReadInNormalForm) {
  const std::string path = tempPath("negative_rho.yaml");
  std::ofstream(path) << "landmarks:\n  - {id: 2, type: line, rho: -2.0, theta: 0.5, "
                         "start: [1, 2], end: [3, 4], covariance: [0.01, 0.002, 0.002, 0.003]}\n";
  const std::vector<LandmarkEstimate> back = io::loadLandmarksYaml(path);
  ASSERT_EQ(back.size(), 1u);
  EXPECT_NEAR(back[0].mean.x(), 2.0, 1e-12);
  EXPECT_NEAR(back[0].mean.y(), 0.5 - M_PI, 1e-12);
  EXPECT_NEAR(back[0].covariance(0, 1), -0.002, 1e-12);
  EXPECT_NEAR(back[0].covariance(1, 0), -0.002, 1e-12);
  EXPECT_NEAR(back[0].covariance(0, 0), 0.01, 1e-12);
  EXPECT_TRUE(back[0].start.isApprox(Eigen::Vector2d(1, 2)));
  // A theta outside [-pi, pi) is wrapped.
  std::ofstream(path) << "landmarks:\n  - {id: 2, type: line, rho: 2.0, theta: 7.0, "
                         "start: [1, 2], end: [3, 4], covariance: [0.01, 0.002, 0.002, 0.003]}\n";
  EXPECT_NEAR(io::loadLandmarksYaml(path)[0].mean.y(), 7.0 - 2.0 * M_PI, 1e-12);
  EXPECT_NEAR(io::loadLandmarksYaml(path)[0].covariance(0, 1), 0.002, 1e-12);
}

TEST(LandmarkFile, BrokenFilesAreRejectedNamingTheEntry) {
  const std::string path = tempPath("broken.yaml");
  auto expectError = [&](const std::string& text, const std::string& expected) {
    std::ofstream(path) << text;
    try {
      io::loadLandmarksYaml(path);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  expectError("landmarks:\n  - {id: 1, type: point, x: 1, covariance: [1, 0, 0, 1]}\n",
              "landmarks[0]: 'y' is missing");
  expectError("landmarks:\n  - {id: 1, type: tree, x: 1, y: 2, covariance: [1, 0, 0, 1]}\n",
              "type = 'tree'");
  expectError("landmarks:\n  - {id: 1, type: point, x: .nan, y: 2, covariance: [1, 0, 0, 1]}\n",
              "'x' is not finite");
  expectError("landmarks:\n  - {id: 1, type: point, x: 1, y: 2, covariance: [1, 0, 0, -1]}\n",
              "not symmetric positive definite");
  // A line from -1e300 to 1e300 m hung the map's index (filed in 2^29 cells).
  expectError(
      "landmarks:\n  - {id: 2, type: line, rho: 0, theta: 1.57, start: [-1e300, 0], "
      "end: [1e300, 1], covariance: [0.01, 0, 0, 0.01]}\n",
      "landmarks[0]: a coordinate beyond 1000000 m");
  expectError("other: 1\n", "'landmarks' (a list) is missing");
  // The ground truth that mrclam_to_bag and simulate write beside their bags has the same
  // file name pattern: say what it is (it used to give "type = '' is not point or line").
  expectError("landmarks:\n  - {id: 6, x_m: 1.5, y_m: 2.7, sd_x_m: 0.001, sd_y_m: 0.001}\n",
              "surveyed positions (x_m, y_m) of a ground-truth file");
  EXPECT_THROW(io::loadLandmarksYaml(tempPath("does_not_exist.yaml")), std::runtime_error);
  // Not a map file at all: empty, a bare list, a single value (each loaded as an empty map).
  expectError("", "'landmarks' (a list) is missing (the file is empty)");
  expectError("- {id: 1, type: point, x: 1, y: 2, covariance: [1, 0, 0, 1]}\n",
              "(the file is not a map of keys)");
  expectError("hello\n", "(the file is not a map of keys)");
  expectError("landmarks:\n  - {id: 4, type: point, x: 1, y: 2, covariance: [1, 0, 0, 1], "
              "observations: 1.5}\n",
              "landmarks[0]: 'observations' must be an integer >= 0");
  // One id twice: which one a sighting with that known id joins would be a guess.
  expectError("landmarks:\n  - {id: 4, type: point, x: 1, y: 2, covariance: [1, 0, 0, 1]}\n"
              "  - {id: 4, type: point, x: 8, y: 2, covariance: [1, 0, 0, 1]}\n",
              "landmarks[1]: id 4 is landmarks[0]'s too");
  // A misspelt or repeated key, or one of the other type, was ignored (the entry loaded with
  // what yaml-cpp kept: the first of two values, the rest defaulted).
  expectError("landmarks:\n  - {id: 4, type: point, x: 1, y: 2, covarience: [1, 0, 0, 1]}\n",
              "landmarks[0]: unknown key 'covarience' (known: covariance, id, observations, "
              "type, x, y)");
  expectError("landmarks:\n  - {id: 4, type: point, x: 1, x: 5, y: 2, covariance: [1, 0, 0, 1]}\n",
              "landmarks[0]: 'x' twice");
  expectError(
      "landmarks:\n  - {id: 4, type: point, x: 1, y: 2, rho: 3, covariance: [1, 0, 0, 1]}\n",
      "landmarks[0]: unknown key 'rho'");
  expectError("landmarks:\n  - 5\n", "landmarks[0]: not a map of keys");
  expectError(
      "count: 1\nlandmark_count: 1\nlandmarks:\n  - {id: 4, type: point, x: 1, y: 2, "
      "covariance: [1, 0, 0, 1]}\n",
      "unknown key 'landmark_count' (known: count, landmarks)");
  // A file cut short at a line boundary still parses: the count written with it tells.
  expectError("count: 2\nlandmarks:\n  - {id: 4, type: point, x: 1, y: 2, "
              "covariance: [1, 0, 0, 1]}\n",
              "count = 2, but 1 landmarks are listed");
  try {
    io::loadLandmarksYaml(::testing::TempDir());
    ADD_FAILURE() << "a directory accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(::testing::TempDir()), std::string::npos) << e.what();
  }
}

// Every number reads back as written: a covariance close to singular stays positive definite
// (with 9 digits [1, 0.99999999995; 0.99999999995, 1] came back as [1, 1; 1, 1] and the map
// could not be loaded again); the count written with the map matches.
TEST(LandmarkFile, NumbersReadBackExactly) {
  std::vector<LandmarkEstimate> map = postMap();
  map[0].covariance << 1.0, 0.99999999995, 0.99999999995, 1.0;
  map[1].mean = Eigen::Vector2d(0.1, 1.0 / 3.0);
  const std::string path = tempPath("exact.yaml");
  io::writeLandmarksYaml(path, map);
  const std::vector<LandmarkEstimate> back = io::loadLandmarksYaml(path);
  ASSERT_EQ(back.size(), map.size());
  EXPECT_EQ(back[0].covariance, map[0].covariance);
  EXPECT_EQ(back[1].mean, map[1].mean);
  io::writeLandmarksYaml(path, {});
  EXPECT_TRUE(io::loadLandmarksYaml(path).empty());  // an empty map is a map
}

TEST(LandmarkFile, GridPictureMarksTheWallCells) {
  LandmarkEstimate wall;
  wall.type = LandmarkType::kLine;
  wall.mean = Eigen::Vector2d(1.0, M_PI / 2);  // y = 1
  wall.covariance = Eigen::Matrix2d::Identity() * 1e-3;
  wall.start = Eigen::Vector2d(0.0, 1.0);
  wall.end = Eigen::Vector2d(2.0, 1.0);
  io::GridMapOptions options;
  options.resolution_m = 0.1;
  options.margin_m = 0.5;
  const auto files = io::writeLandmarkGrid(tempPath("grid"), {wall}, options);
  ASSERT_EQ(files.size(), 2u);
  std::ifstream pgm(files[0], std::ios::binary);
  std::string magic;
  int width = 0, height = 0, max = 0;
  pgm >> magic;
  pgm.ignore(1);
  while (pgm.peek() == '#') pgm.ignore(1000, '\n');
  pgm >> width >> height >> max;
  pgm.ignore(1);
  EXPECT_EQ(magic, "P5");
  EXPECT_EQ(width, 30);   // 2 m + 2 x 0.5 m at 0.1 m
  EXPECT_EQ(height, 10);  // 0 m + 2 x 0.5 m
  std::vector<unsigned char> cells(width * height);
  pgm.read(reinterpret_cast<char*>(cells.data()), cells.size());
  int occupied = 0;
  for (unsigned char c : cells) occupied += c == 0;
  EXPECT_GE(occupied, 20);  // the 2 m wall at 0.1 m
  EXPECT_LE(occupied, 22);
  std::ifstream yaml(files[1]);
  const std::string text((std::istreambuf_iterator<char>(yaml)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("resolution: 0.1"), std::string::npos) << text;
  EXPECT_NE(text.find("origin: [-0.5, 0.5, 0.0]"), std::string::npos) << text;
}

core::FilterOptions pointFilterOptions() {
  core::FilterOptions options;
  options.particles = 50;
  options.seed = 3;
  options.use_lines = false;
  return options;
}

TEST(Localization, LoadedMapStaysFixedAndTheRobotIsFoundOnIt) {
  core::FastSlam2 filter(pointFilterOptions());
  const std::vector<LandmarkEstimate> map = postMap();
  ASSERT_TRUE(filter.loadMap(map));
  ASSERT_TRUE(filter.setMapping(false));
  // Started 0.36 m and 0.1 rad off, the robot drives 3 m; the observations pull the
  // filter onto the map.
  Pose2 truth(0.0, 0.0, 0.0);
  ASSERT_TRUE(filter.resetPose(Pose2(0.3, -0.2, 0.1), Eigen::Vector3d(0.1, 0.1, 0.02).asDiagonal()));
  core::PointFeature unknown;  // a post that is not on the map: must not be added
  unknown.range = 2.0;
  unknown.bearing = 2.5;
  unknown.covariance = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  for (int step = 0; step < 30; ++step) {
    core::MotionInput forward;
    forward.delta = Pose2(0.1, 0.0, 0.0);
    forward.dt = 0.5;
    filter.predict(forward);
    truth = core::compose(truth, forward.delta);
    core::FeatureSet features = observe(map, truth);
    features.points.push_back(unknown);
    filter.update(features);
  }
  const Pose2 estimate = filter.estimate().mean;
  EXPECT_LT((estimate.head<2>() - truth.head<2>()).norm(), 0.05) << estimate.transpose();
  EXPECT_LT(std::fabs(core::wrapAngle(estimate.z() - truth.z())), 0.02);
  const std::vector<LandmarkEstimate> after = filter.landmarks();
  ASSERT_EQ(after.size(), map.size()) << "localization-only added a landmark";
  for (size_t i = 0; i < map.size(); ++i) {
    EXPECT_EQ(after[i].id, map[i].id);
    EXPECT_TRUE(after[i].mean.isApprox(map[i].mean, 1e-12)) << "a map landmark moved";
  }
}

TEST(Localization, MappingOnAddsToTheLoadedMap) {
  core::FastSlam2 filter(pointFilterOptions());
  const std::vector<LandmarkEstimate> map = postMap();
  ASSERT_TRUE(filter.loadMap(map));
  core::FeatureSet features = observe(map, Pose2::Zero());
  core::PointFeature unknown;
  unknown.range = 2.0;
  unknown.bearing = 2.5;
  unknown.covariance = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  features.points.push_back(unknown);
  filter.predict(core::MotionInput());
  filter.update(features);
  const std::vector<LandmarkEstimate> after = filter.landmarks();
  ASSERT_EQ(after.size(), map.size() + 1);
  EXPECT_GT(after.back().id, 13) << "new ids must not collide with the loaded ones";
}

TEST(Localization, ResetPoseRejectsBrokenInput) {
  core::FastSlam2 filter(pointFilterOptions());
  EXPECT_FALSE(filter.resetPose(Pose2(NAN, 0, 0), Eigen::Matrix3d::Identity()));
  EXPECT_FALSE(filter.resetPose(Pose2::Zero(), -Eigen::Matrix3d::Identity()));
  EXPECT_TRUE(filter.resetPose(Pose2(1, 2, 3), Eigen::Matrix3d::Zero()));
  for (const auto& p : filter.particles()) EXPECT_LT((p.pose - Pose2(1, 2, 3)).norm(), 1e-4);
}

// A positive diagonal is not enough: xx = yy = 0.25 with xy = 1 is indefinite. Before the first
// frame the session only stores the pose, so it must check the covariance itself (the filter's
// refusal at the first frame used to be ignored).
TEST(Localization, SessionRefusesACovarianceThatIsNotPositiveSemiDefinite) {
  Eigen::Matrix3d indefinite = Eigen::Vector3d(0.25, 0.25, 0.0685).asDiagonal();
  indefinite(0, 1) = indefinite(1, 0) = 1.0;
  Eigen::Matrix3d asymmetric = Eigen::Vector3d(0.25, 0.25, 0.0685).asDiagonal();
  asymmetric(0, 1) = 0.1;
  EXPECT_FALSE(core::poseCovarianceUsable(indefinite));
  EXPECT_FALSE(core::poseCovarianceUsable(asymmetric));
  EXPECT_TRUE(core::poseCovarianceUsable(Eigen::Matrix3d::Zero()));
  EXPECT_TRUE(core::poseCovarianceUsable(Eigen::Vector3d(0.25, 0.25, 0.0).asDiagonal()));
  core::SlamSession session(std::make_unique<core::FastSlam2>(pointFilterOptions()),
                            core::SessionOptions());
  EXPECT_FALSE(session.setPose(Pose2(1, 2, 0), indefinite));  // before the first frame
  session.process(1.0, Pose2::Zero(), core::FeatureSet());
  EXPECT_LT(session.filter().estimate().mean.head<2>().norm(), 0.1);  // at the origin, not (1, 2)
  EXPECT_FALSE(session.setPose(Pose2(1, 2, 0), indefinite));  // after it
  EXPECT_TRUE(session.setPose(Pose2(1, 2, 0), Eigen::Vector3d(0.25, 0.25, 0.0685).asDiagonal()));
}

// Every variant refuses an indefinite covariance itself (not only the
// session and the node), and takes one whose off-diagonal pair differs by float32 rounding.
TEST(Localization, EveryVariantRefusesAnIndefiniteCovarianceAndTakesAFloat32One) {
  Eigen::Matrix3d indefinite = Eigen::Vector3d(0.25, 0.25, 0.0685).asDiagonal();
  indefinite(0, 1) = indefinite(1, 0) = 1.0;
  Eigen::Matrix3d float32 = Eigen::Vector3d(0.25, 0.25, 0.0685).asDiagonal();
  float32(0, 1) = static_cast<float>(0.1 / 3.0);
  float32(1, 0) = 0.1 / 3.0;  // the pair differs by ~1e-9 of 0.033: the entries' float rounding
  ASSERT_NE(float32(0, 1), float32(1, 0));
  EXPECT_TRUE(core::poseCovarianceUsable(float32));
  int checked = 0;
  for (const std::string& variant : core::availableVariants()) {
    core::FilterOptions options = pointFilterOptions();
    options.variant = variant;
    options.particles = 20;
    std::unique_ptr<core::SlamFilter> filter = core::createFilter(options);
    const Pose2 start = filter->estimate().mean;
    EXPECT_FALSE(filter->resetPose(Pose2(1, 2, 0), indefinite)) << variant;
    EXPECT_LT((filter->estimate().mean - start).norm(), 1e-9) << variant << " moved anyway";
    EXPECT_TRUE(filter->resetPose(Pose2(1, 2, 0), float32)) << variant;
    EXPECT_LT((filter->estimate().mean.head<2>() - Eigen::Vector2d(1, 2)).norm(), 0.6) << variant;
    double spread = 0.0;  // the particles are drawn from the covariance, not all at (1, 2)
    for (const auto& p : filter->particles()) spread = std::max(spread, (p.pose - Pose2(1, 2, 0)).norm());
    if (variant != "ekf_slam") {
      EXPECT_GT(spread, 0.05) << variant;
    }
    ++checked;
  }
  EXPECT_EQ(checked, static_cast<int>(core::availableVariants().size()));
}

TEST(Localization, SessionStartsAtTheGivenPoseOnThePriorMap) {
  core::SlamSession session(std::make_unique<core::FastSlam2>(pointFilterOptions()),
                            core::SessionOptions());
  const std::vector<LandmarkEstimate> map = postMap();
  ASSERT_TRUE(session.setPriorMap(map));
  ASSERT_TRUE(session.setMapping(false));
  const Pose2 truth(0.5, 0.5, 0.2);
  ASSERT_TRUE(session.setPose(truth, Eigen::Vector3d(1e-4, 1e-4, 1e-5).asDiagonal()));
  // Odometry starts at (10, 10): map -> odom must take it to the given pose.
  const Pose2 odom(10.0, 10.0, -1.0);
  session.process(1.0, odom, observe(map, truth));
  const Pose2 base_in_map = core::compose(session.mapToOdom(), odom);
  EXPECT_LT((base_in_map.head<2>() - truth.head<2>()).norm(), 0.05) << base_in_map.transpose();
  EXPECT_EQ(session.filter().landmarks().size(), map.size());
  // A reset (clock jumped back) keeps the prior map.
  session.reset();
  EXPECT_EQ(session.filter().landmarks().size(), map.size());
}

}  // namespace
}  // namespace rbpf_slam
