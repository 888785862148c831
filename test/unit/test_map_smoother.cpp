// The smoother of a finished run (map_smoother.h): from a jittered path and a displaced map
// with exact odometry and sightings it recovers the true ones; it keeps the association of the
// filter's map, leaves out sightings outside every gate, wraps odometry steps across +-pi,
// refuses bad input by name, and works on a session that kept its frames.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <cmath>
#include <random>
#include <vector>

#include "rbpf_slam/core/alignment.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/slam/map_smoother.h"

namespace rbpf_slam {
namespace {

using core::Pose2;

/// A robot driving a circle of radius 3 m around four landmarks, seeing each one in range.
struct Scene {
  std::vector<Pose2> truth;
  std::vector<Eigen::Vector2d> points{{0.5, 0.5}, {-1.0, 1.0}, {-0.5, -1.5}, {2.0, -0.5}};
  std::vector<core::SmoothingFrame> frames;
};

core::Observation sighting(const Pose2& pose, const Eigen::Vector2d& point) {
  core::Observation o;
  o.z = core::predictPoint(pose, point).z;
  o.noise = Eigen::Vector2d(0.05 * 0.05, 0.02 * 0.02).asDiagonal();
  return o;
}

/// One frame per true pose: the exact odometry from the pose before, every point sighted.
void addExactFrames(Scene* scene) {
  for (size_t i = 0; i < scene->truth.size(); ++i) {
    core::SmoothingFrame f;
    if (i > 0) f.motion = core::between(scene->truth[i - 1], scene->truth[i]);
    f.motion_covariance = Eigen::Vector3d(0.02 * 0.02, 0.02 * 0.02, 0.02 * 0.02).asDiagonal();
    for (const Eigen::Vector2d& p : scene->points) {
      f.observations.push_back(sighting(scene->truth[i], p));
    }
    scene->frames.push_back(f);
  }
}

Scene circle(int steps) {
  Scene scene;
  for (int i = 0; i < steps; ++i) {
    const double a = 2.0 * M_PI * i / steps;
    scene.truth.emplace_back(3.0 * std::cos(a), 3.0 * std::sin(a), core::wrapAngle(a + M_PI / 2));
  }
  addExactFrames(&scene);
  return scene;
}

std::vector<core::LandmarkEstimate> mapOf(const std::vector<Eigen::Vector2d>& points) {
  std::vector<core::LandmarkEstimate> map;
  for (size_t k = 0; k < points.size(); ++k) {
    core::LandmarkEstimate l;
    l.id = static_cast<int>(k) + 10;
    l.mean = points[k];
    l.covariance = 0.01 * Eigen::Matrix2d::Identity();
    l.observations = 7;  // the filter's count, kept as it is
    map.push_back(l);
  }
  return map;
}

TEST(MapSmoother, RecoversTheTruePathAndMapFromAJitteredSample) {
  const Scene scene = circle(40);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> xy(0.0, 0.05), heading(0.0, 0.015);
  std::vector<Pose2> path = scene.truth;
  for (size_t i = 1; i < path.size(); ++i) path[i] += Pose2(xy(rng), xy(rng), heading(rng));
  std::vector<Eigen::Vector2d> displaced = scene.points;
  for (Eigen::Vector2d& p : displaced) p += Eigen::Vector2d(0.08, -0.06);
  core::SmoothingOptions options;
  options.enabled = true;
  const core::SmoothingResult r =
      core::smoothPathAndMap(path, scene.frames, mapOf(displaced), options);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.sightings_used, 160);
  EXPECT_EQ(r.sightings_left_out, 0);
  EXPECT_EQ(r.landmarks_smoothed, 4);
  EXPECT_LT(r.final_cost, 1e-6 * r.initial_cost);
  double before = 0.0, after = 0.0;
  for (size_t i = 0; i < path.size(); ++i) {
    before = std::max(before, (path[i] - scene.truth[i]).head<2>().norm());
    after = std::max(after, (r.path[i] - scene.truth[i]).head<2>().norm());
    EXPECT_NEAR(core::wrapAngle(r.path[i].z() - scene.truth[i].z()), 0.0, 1e-5) << i;
  }
  EXPECT_GT(before, 0.05);
  EXPECT_LT(after, 1e-5);
  for (size_t k = 0; k < scene.points.size(); ++k) {
    EXPECT_LT((r.landmarks[k].mean - scene.points[k]).norm(), 1e-5) << k;
    EXPECT_EQ(r.landmarks[k].id, static_cast<int>(k) + 10);  // ids kept
    EXPECT_EQ(r.landmarks[k].observations, 7);
    // The covariance given the path: (sum over the sightings of H^T R^-1 H)^-1 at the truth.
    Eigen::Matrix2d information = Eigen::Matrix2d::Zero();
    for (size_t i = 0; i < scene.truth.size(); ++i) {
      const core::Prediction p = core::predictPoint(scene.truth[i], scene.points[k]);
      information += p.h_landmark.transpose() *
                     scene.frames[i].observations[k].noise.inverse() * p.h_landmark;
    }
    const Eigen::Matrix2d expected = information.inverse();
    EXPECT_LT((r.landmarks[k].covariance - expected).norm(), 1e-6 * expected.norm()) << k;
  }
}

// Odometry steps of nearly half a turn (pi - 0.01 rad), with the sample's headings off so that
// its step crosses +-pi (pi + 0.01, i.e. -pi + 0.01 once wrapped): the odometry residual must
// wrap, or the solver chases a 2 pi error and cannot recover the truth.
TEST(MapSmoother, HalfTurnStepsAcrossPiAreWrapped) {
  Scene scene;
  scene.points = {{1.0, 2.0}, {3.0, -2.0}, {5.0, 2.0}, {2.0, -1.5}};
  const int steps = 20;
  for (int i = 0; i < steps; ++i) {
    scene.truth.emplace_back(0.3 * i, 0.1 * (i % 2), core::wrapAngle(i * (M_PI - 0.01)));
  }
  addExactFrames(&scene);
  ASSERT_NEAR(scene.frames[1].motion.z(), M_PI - 0.01, 1e-9);
  std::vector<Pose2> path = scene.truth;
  for (int i = 1; i < steps; i += 2) {
    path[i] += Pose2(0.04, -0.03, 0.02);
    path[i].z() = core::wrapAngle(path[i].z());
  }
  ASSERT_NEAR(core::between(path[0], path[1]).z(), -M_PI + 0.01, 1e-9);  // across pi
  core::SmoothingOptions options;
  const core::SmoothingResult r = core::smoothPathAndMap(path, scene.frames,
                                                         mapOf(scene.points), options);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.sightings_left_out, 0);
  EXPECT_LT(r.final_cost, 1e-6 * r.initial_cost);
  for (int i = 0; i < steps; ++i) {
    EXPECT_LT((r.path[i] - scene.truth[i]).head<2>().norm(), 1e-5) << i;
    EXPECT_NEAR(core::wrapAngle(r.path[i].z() - scene.truth[i].z()), 0.0, 1e-5) << i;
  }
}

// With noisy odometry and sightings the smoothed path is closer to the truth than a jittered
// sample of it (the filter's best particle), and the first pose is held where it was.
TEST(MapSmoother, NoisyDataSmoothedPathBeatsTheSample) {
  Scene scene = circle(60);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> unit(0.0, 1.0);
  for (size_t i = 0; i < scene.frames.size(); ++i) {
    if (i > 0) scene.frames[i].motion += Pose2(0.02 * unit(rng), 0.02 * unit(rng), 0.02 * unit(rng));
    for (core::Observation& o : scene.frames[i].observations) {
      o.z += Eigen::Vector2d(0.05 * unit(rng), 0.02 * unit(rng));
    }
  }
  std::vector<Pose2> path = scene.truth;
  for (size_t i = 1; i < path.size(); ++i) {
    path[i] += Pose2(0.1 * unit(rng), 0.1 * unit(rng), 0.05 * unit(rng));
  }
  core::SmoothingOptions options;
  const core::SmoothingResult r = core::smoothPathAndMap(path, scene.frames,
                                                         mapOf(scene.points), options);
  ASSERT_TRUE(r.ok) << r.message;
  const double before = core::alignedRmsDistance(path, scene.truth);
  const double after = core::alignedRmsDistance(r.path, scene.truth);
  EXPECT_GT(before, 0.1);
  EXPECT_LT(after, 0.3 * before);
  EXPECT_LT((r.path[0] - path[0]).norm(), 1e-6);
}

TEST(MapSmoother, SightingsOutsideEveryGateAreLeftOut) {
  Scene scene = circle(20);
  // A sighting of something at (6, 6), 3.5 m or more from every mapped landmark, in every frame.
  for (size_t i = 0; i < scene.frames.size(); ++i) {
    scene.frames[i].observations.push_back(sighting(scene.truth[i], Eigen::Vector2d(6.0, 6.0)));
  }
  core::SmoothingOptions options;
  options.min_sightings = 2;
  const core::SmoothingResult r =
      core::smoothPathAndMap(scene.truth, scene.frames, mapOf(scene.points), options);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.sightings_left_out, 20);
  EXPECT_EQ(r.sightings_used, 80);
}

// A sighting with a known id joins the landmark of that id wherever it is, or none.
TEST(MapSmoother, SightingsWithAKnownIdJoinThatLandmark) {
  Scene scene = circle(20);
  for (core::SmoothingFrame& f : scene.frames) {
    f.observations[0].known_id = 13;  // the first point, labelled as the fourth
    f.observations[1].known_id = 99;  // an id not in the map
  }
  core::SmoothingOptions options;
  options.min_sightings = 1;
  const core::SmoothingResult r =
      core::smoothPathAndMap(scene.truth, scene.frames, mapOf(scene.points), options);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.sightings_used, 60);
  EXPECT_EQ(r.sightings_left_out, 20);
  // The first landmark has no sighting left: it is not smoothed, and stays exactly as given.
  EXPECT_EQ(r.landmarks_smoothed, 2);
  EXPECT_EQ(r.landmarks[0].mean, scene.points[0]);
  EXPECT_EQ(r.landmarks[0].covariance, 0.01 * Eigen::Matrix2d::Identity());
  // Pulled towards the first point (the Huber kernel limits how far).
  EXPECT_GT((r.landmarks[3].mean - scene.points[3]).norm(), 0.05);
}

// Sightings 2.6 sigma off (inside the gate) in a third of the frames: the Huber kernel lets
// them pull the landmark less than plain least squares does.
TEST(MapSmoother, TheHuberKernelResistsSightingsFarOff) {
  Scene scene = circle(30);
  for (size_t i = 0; i < scene.frames.size(); i += 3) scene.frames[i].observations[0].z.x() += 0.13;
  core::SmoothingOptions options;
  double error[2];
  for (int robust = 0; robust < 2; ++robust) {
    options.huber_k = robust ? 2.0 : 0.0;
    const core::SmoothingResult r =
        core::smoothPathAndMap(scene.truth, scene.frames, mapOf(scene.points), options);
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_EQ(r.sightings_used, 120);
    error[robust] = (r.landmarks[0].mean - scene.points[0]).norm();
  }
  EXPECT_GT(error[0], 0.01);
  EXPECT_LT(error[1], 0.9 * error[0]);
}

/// Rotates a point or a pose by angle about the origin.
Eigen::Vector2d rotated(const Eigen::Vector2d& p, double angle) {
  return Eigen::Rotation2Dd(angle) * p;
}
Pose2 rotated(const Pose2& p, double angle) {
  const Eigen::Vector2d xy = rotated(Eigen::Vector2d(p.head<2>()), angle);
  return Pose2(xy.x(), xy.y(), core::wrapAngle(p.z() + angle));
}

// A filter that lost its heading in a silence (frame 20, odometry of little weight that turns
// the robot 0.5 rad too far) maps the landmarks it meets again as copies: the second lap's path
// and copies are the truth turned by 0.5 rad about the centre, which that odometry agrees with
// exactly. Without merging the smoother keeps both maps (each lap explains its own sightings at
// no cost); with merging it joins each copy to its landmark, turns the second lap back (at a
// cost: the silence's odometry now disagrees by 0.5 rad) and, associating again, takes in a
// sighting left out before. The copies are sighted in two more frames than the landmarks, so
// they keep their ids (the higher indices merged into).
TEST(MapSmoother, CopiesMappedAfterASilenceAreMerged) {
  Scene scene;
  scene.points = {{0.5, 0.5}, {-1.0, 1.0}, {-0.5, -1.5}, {2.0, -0.5}};
  const int steps = 40;
  const std::vector<Pose2> lap = circle(steps / 2).truth;
  scene.truth = lap;  // two laps
  scene.truth.insert(scene.truth.end(), lap.begin(), lap.end());
  addExactFrames(&scene);
  const double turn = 0.5;
  std::vector<Pose2> path = scene.truth;
  for (int i = 20; i < steps; ++i) path[i] = rotated(scene.truth[i], turn);
  scene.frames[20].motion = core::between(path[19], path[20]);
  scene.frames[20].motion_covariance = Eigen::Vector3d(1.0, 1.0, 0.5 * 0.5).asDiagonal();
  for (int i = 0; i < steps; ++i) {
    auto& o = scene.frames[i].observations;
    if (i < 2) o.erase(o.begin(), o.begin() + 3);  // the first three unseen in frames 0 and 1
    if (i >= 20 && i != 30) o.pop_back();  // the fourth seen once on the second lap
  }
  std::vector<Eigen::Vector2d> mapped = scene.points;  // ids 10-13
  for (int k = 0; k < 3; ++k) mapped.push_back(rotated(scene.points[k], turn));  // ids 14-16

  core::SmoothingOptions options;
  const core::SmoothingResult kept = core::smoothPathAndMap(path, scene.frames, mapOf(mapped),
                                                            options);
  ASSERT_TRUE(kept.ok) << kept.message;
  EXPECT_EQ(kept.landmarks_smoothed, 7);
  EXPECT_EQ(kept.landmarks_merged, 0);
  EXPECT_EQ(kept.sightings_left_out, 1);  // the fourth's, seen from the turned lap
  EXPECT_LT(kept.final_cost, 1e-6);
  EXPECT_GT((kept.path[30] - scene.truth[30]).head<2>().norm(), 1.0);

  // The merges cost +0.08 (the second lap turns about the merged landmark), then +3.1 (the
  // silence's odometry gives way), then next to nothing: each limit stops the greedy merging.
  for (const auto& [limit, merges] : {std::pair<double, int>{0.05, 0}, {1.0, 1}}) {
    options.merge_max_cost = limit;
    const core::SmoothingResult dear =
        core::smoothPathAndMap(path, scene.frames, mapOf(mapped), options);
    ASSERT_TRUE(dear.ok) << dear.message;
    EXPECT_EQ(dear.landmarks_merged, merges) << dear.message;
    EXPECT_EQ(dear.landmarks.size(), 7u - merges);
  }

  options.merge_max_cost = 30.0;
  const core::SmoothingResult r = core::smoothPathAndMap(path, scene.frames, mapOf(mapped),
                                                         options);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.landmarks_merged, 3) << r.message;
  EXPECT_NE(r.message.find("merged 1"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find(" into 14"), std::string::npos) << r.message;
  ASSERT_EQ(r.landmarks.size(), 4u);
  EXPECT_EQ(r.landmarks_smoothed, 4);
  EXPECT_EQ(r.sightings_left_out, 0);  // associated again at the merged path
  EXPECT_EQ(r.sightings_used, 3 * 38 + 21);
  EXPECT_GT(r.final_cost, 0.5);  // the silence's odometry is off now
  EXPECT_EQ(r.landmarks[0].id, 13);
  EXPECT_LT((r.landmarks[0].mean - scene.points[3]).norm(), 1e-2);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(r.landmarks[k + 1].id, k + 14);        // the copies' ids
    EXPECT_EQ(r.landmarks[k + 1].observations, 14);  // both counts
    EXPECT_LT((r.landmarks[k + 1].mean - scene.points[k]).norm(), 1e-2) << k;
  }
  for (int i = 0; i < steps; ++i) {
    EXPECT_LT((r.path[i] - scene.truth[i]).head<2>().norm(), 1e-2) << i;
    EXPECT_NEAR(core::wrapAngle(r.path[i].z() - scene.truth[i].z()), 0.0, 1e-2) << i;
  }
}

// Two landmarks 0.3 m apart, one seen on the first lap and the other on the second, with exact
// odometry: merging them would cost far more than merge_max_cost, so both stay. Two landmarks
// sighted in one frame are never merged, however close and however cheap.
TEST(MapSmoother, DistinctLandmarksAreNotMerged) {
  Scene scene;
  scene.points = {{0.5, 0.5}, {-1.0, 1.0}, {-0.5, -1.5}, {0.5, 0.8}};
  const int steps = 40;
  const std::vector<Pose2> lap = circle(steps / 2).truth;
  scene.truth = lap;  // two laps
  scene.truth.insert(scene.truth.end(), lap.begin(), lap.end());
  addExactFrames(&scene);
  for (int i = 0; i < steps; ++i) {  // the first point on lap 1 only, the fourth on lap 2 only
    auto& o = scene.frames[i].observations;
    o.erase(o.begin() + (i < 20 ? 3 : 0));
  }
  core::SmoothingOptions options;
  options.merge_max_cost = 30.0;
  core::SmoothingResult r =
      core::smoothPathAndMap(scene.truth, scene.frames, mapOf(scene.points), options);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.landmarks_merged, 0);
  EXPECT_EQ(r.landmarks.size(), 4u);
  EXPECT_EQ(r.message.find("merged"), std::string::npos) << r.message;

  // The same two seen together in every frame, 0.05 m apart: not a candidate pair.
  scene = Scene();
  scene.points = {{0.5, 0.5}, {-1.0, 1.0}, {-0.5, -1.5}, {0.5, 0.55}};
  scene.truth = circle(20).truth;
  addExactFrames(&scene);
  options.merge_max_cost = 1e6;
  r = core::smoothPathAndMap(scene.truth, scene.frames, mapOf(scene.points), options);
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.landmarks_merged, 0);
  EXPECT_EQ(r.landmarks.size(), 4u);
}

// Nothing to smooth (no landmark seen often enough) is a refusal, not a dead-reckoned path.
TEST(MapSmoother, NoSightingIsARefusal) {
  const Scene scene = circle(10);
  core::SmoothingOptions options;
  options.min_sightings = 11;
  const core::SmoothingResult r =
      core::smoothPathAndMap(scene.truth, scene.frames, mapOf(scene.points), options);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("nothing to smooth"), std::string::npos) << r.message;
}

TEST(MapSmoother, BadInputIsRefusedByName) {
  const Scene scene = circle(10);
  core::SmoothingOptions options;
  std::vector<Pose2> path = scene.truth;
  path.pop_back();
  core::SmoothingResult r = core::smoothPathAndMap(path, scene.frames, mapOf(scene.points),
                                                   options);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("differ in length"), std::string::npos) << r.message;
  EXPECT_EQ(r.path, path);  // the input is handed back
  path = scene.truth;
  path[4].x() = std::nan("");
  r = core::smoothPathAndMap(path, scene.frames, mapOf(scene.points), options);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("pose 4"), std::string::npos) << r.message;
  std::vector<core::SmoothingFrame> frames = scene.frames;
  frames[3].motion_covariance.setZero();
  r = core::smoothPathAndMap(scene.truth, frames, mapOf(scene.points), options);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("frame 3"), std::string::npos) << r.message;
  frames = scene.frames;
  frames[6].observations[1].z.y() = std::nan("");
  r = core::smoothPathAndMap(scene.truth, frames, mapOf(scene.points), options);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("observation of frame 6"), std::string::npos) << r.message;
  options.gate_chi2 = -1.0;
  EXPECT_THROW(core::smoothPathAndMap(scene.truth, scene.frames, mapOf(scene.points), options),
               std::invalid_argument);
  options = core::SmoothingOptions();
  options.merge_max_cost = -1.0;
  try {
    core::smoothPathAndMap(scene.truth, scene.frames, mapOf(scene.points), options);
    ADD_FAILURE() << "a negative merge_max_cost was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("smoothing.merge_max_cost"), std::string::npos)
        << e.what();
  }
  options.merge_max_cost = 30.0;  // merging on, but only of points at one spot
  options.merge_max_distance_m = 0.0;
  try {
    core::smoothPathAndMap(scene.truth, scene.frames, mapOf(scene.points), options);
    ADD_FAILURE() << "merge_max_distance_m 0 with merging on was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("smoothing.merge_max_distance_m must be > 0"),
              std::string::npos)
        << e.what();
  }
}

// A session keeps one frame per trajectory point only when asked to, and smoothSession then
// smooths the filter's best path; without kept frames it says why and changes nothing.
TEST(MapSmoother, SmoothsASessionThatKeptItsFrames) {
  const Scene scene = circle(30);
  core::FilterOptions filter;
  filter.particles = 20;
  filter.use_lines = false;
  filter.measurement.sigma_range_m = 0.05;
  filter.measurement.sigma_bearing_rad = 0.02;
  for (bool keep : {false, true}) {
    core::SessionOptions options;
    options.keep_frames = keep;
    core::SlamSession session(core::createFilter(filter), options);
    for (size_t i = 0; i < scene.truth.size(); ++i) {
      core::FeatureSet features;
      features.stamp = 1.0 + i;
      for (const Eigen::Vector2d& p : scene.points) {
        const core::Observation o = sighting(scene.truth[i], p);
        core::PointFeature f;
        f.range = o.z.x();
        f.bearing = o.z.y();
        f.covariance = o.noise;
        features.points.push_back(f);
      }
      session.process(features.stamp, scene.truth[i], features);
    }
    ASSERT_EQ(session.trajectory().size(), scene.truth.size());
    EXPECT_EQ(session.frames().size(), keep ? scene.truth.size() : 0u);
    core::SmoothingOptions smoothing;
    smoothing.enabled = true;
    const core::SmoothingResult r = core::smoothSession(session, filter, smoothing);
    EXPECT_EQ(r.ok, keep) << r.message;
    if (!keep) {
      EXPECT_NE(r.message.find("keep_frames"), std::string::npos) << r.message;
      continue;
    }
    EXPECT_EQ(r.landmarks_smoothed, 4);
    // The map frame is the first odometry pose: the smoothed map is the true one.
    for (const core::LandmarkEstimate& l : r.landmarks) {
      double nearest = 1e9;
      for (const Eigen::Vector2d& p : scene.points) nearest = std::min(nearest, (l.mean - p).norm());
      EXPECT_LT(nearest, 0.02);
    }
    // The smoothed path is the one the runner reports: one pose per trajectory point.
    EXPECT_EQ(r.path.size(), session.estimatedPath().size());
    // A pose reset during the run breaks the path: the frames are dropped until a reset, and
    // smoothing says why instead of smoothing across the jump.
    ASSERT_TRUE(session.setPose(core::Pose2(1.0, 1.0, 0.5), 1e-4 * Eigen::Matrix3d::Identity()));
    EXPECT_TRUE(session.frames().empty());
    core::FeatureSet later;
    later.stamp = 100.0;
    session.process(later.stamp, scene.truth[0], later);
    EXPECT_TRUE(session.frames().empty());
    const core::SmoothingResult broken = core::smoothSession(session, filter, smoothing);
    EXPECT_FALSE(broken.ok);
    EXPECT_NE(broken.message.find("pose was reset"), std::string::npos) << broken.message;
    session.reset();
    session.process(200.0, scene.truth[0], later);
    EXPECT_EQ(session.frames().size(), 1u);  // kept again after the reset
    // On a prior map the map frame is the map's: nothing is smoothed.
    ASSERT_TRUE(session.setPriorMap(mapOf(scene.points)));
    EXPECT_NE(core::smoothSession(session, filter, smoothing).message.find("prior map"),
              std::string::npos);
  }
}

}  // namespace
}  // namespace rbpf_slam
