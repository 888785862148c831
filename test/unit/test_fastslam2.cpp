// FastSLAM 2.0 on a synthetic world with known walls and posts: Jacobians against finite
// differences, resampling properties, and the filter beating odometry within a bound.

#include <gtest/gtest.h>

#include <Eigen/LU>

#include <cmath>
#include <random>

#include "rbpf_slam/core/alignment.h"
#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/filters/resampling.h"
#include "synthetic_world.h"

namespace rbpf_slam {
namespace core {
namespace {

template <typename F>
Eigen::MatrixXd numericJacobian(F f, const Eigen::VectorXd& x, int rows, bool wrap_second) {
  Eigen::MatrixXd j(rows, x.size());
  const double h = 1e-6;
  for (int i = 0; i < x.size(); ++i) {
    Eigen::VectorXd a = x, b = x;
    a(i) += h;
    b(i) -= h;
    Eigen::VectorXd d = f(a) - f(b);
    if (wrap_second) d(1) = wrapAngle(d(1));
    j.col(i) = d / (2 * h);
  }
  return j;
}

TEST(MeasurementModels, PointJacobiansMatchFiniteDifferences) {
  const Pose2 pose(1.0, -2.0, 0.7);
  const Eigen::Vector2d point(4.0, 1.5);
  const Prediction p = predictPoint(pose, point);
  const auto by_pose = numericJacobian(
      [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return predictPoint(x, point).z; },
      pose, 2, true);
  const auto by_point = numericJacobian(
      [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
        return predictPoint(pose, x.head<2>()).z;
      },
      point, 2, true);
  EXPECT_TRUE(p.h_pose.isApprox(by_pose, 1e-5)) << p.h_pose << "\n" << by_pose;
  EXPECT_TRUE(p.h_landmark.isApprox(by_point, 1e-5)) << p.h_landmark << "\n" << by_point;
}

TEST(MeasurementModels, LineJacobiansMatchFiniteDifferencesOnBothSides) {
  for (double rho : {3.0, 0.5}) {  // robot on either side of the line
    const Pose2 pose(1.0, 2.0, 0.3);
    const Eigen::Vector2d line(rho, 1.1);
    const double observed = predictLine(pose, line, NAN).z.y();
    const Prediction p = predictLine(pose, line, observed);
    const auto by_pose = numericJacobian(
        [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
          return predictLine(x, line, observed).z;
        },
        pose, 2, true);
    const auto by_line = numericJacobian(
        [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
          return predictLine(pose, x.head<2>(), observed).z;
        },
        line, 2, true);
    EXPECT_TRUE(p.h_pose.isApprox(by_pose, 1e-5)) << p.h_pose << "\n" << by_pose;
    EXPECT_TRUE(p.h_landmark.isApprox(by_line, 1e-5)) << p.h_landmark << "\n" << by_line;
  }
}

TEST(MeasurementModels, InverseModelsRoundTrip) {
  const Pose2 pose(-1.0, 0.5, 2.5);
  const Eigen::Vector2d z_point(3.0, -0.4), z_line(1.2, 0.8);
  EXPECT_TRUE(predictPoint(pose, pointFromObservation(pose, z_point, nullptr)).z.isApprox(z_point));
  const Eigen::Vector2d line = lineFromObservation(pose, z_line, nullptr);
  EXPECT_GE(line.x(), 0.0);
  EXPECT_TRUE(predictLine(pose, line, z_line.y()).z.isApprox(z_line, 1e-9));
  Eigen::Matrix2d g;
  lineFromObservation(pose, z_line, &g);
  const auto numeric = numericJacobian(
      [&](const Eigen::VectorXd& z) -> Eigen::VectorXd {
        return lineFromObservation(pose, z.head<2>(), nullptr);
      },
      z_line, 2, true);
  EXPECT_TRUE(g.isApprox(numeric, 1e-5));
}

TEST(Resampling, LowVarianceKeepsProportionsAndIsDeterministic) {
  const std::vector<double> weights{0.5, 0.25, 0.125, 0.125, 0.0};
  Rng rng(7);
  const std::vector<int> drawn = resampleLowVariance(weights, 8, rng);
  std::vector<int> counts(5, 0);
  for (int i : drawn) ++counts[i];
  EXPECT_EQ(counts, (std::vector<int>{4, 2, 1, 1, 0}));  // exact for dyadic weights
  Rng a(3), b(3);
  EXPECT_EQ(resampleLowVariance({0.3, 0.7}, 10, a), resampleLowVariance({0.3, 0.7}, 10, b));
}

// KLD-sampling's bound (Fox 2003, eq. 13), against values worked by hand: 1 bin needs one
// sample; k bins need (k - 1) / (2 error) (1 - b + sqrt(b) z)^3 with b = 2 / (9 (k - 1)).
TEST(Resampling, KldBoundFollowsFoxsFormula) {
  EXPECT_EQ(kldSampleBound(0, 0.01, 2.33), 1);
  EXPECT_EQ(kldSampleBound(1, 0.01, 2.33), 1);
  EXPECT_EQ(kldSampleBound(2, 0.01, 2.33), 331);     // 330.197
  EXPECT_EQ(kldSampleBound(3, 0.01, 2.33), 463);     // 462.038
  EXPECT_EQ(kldSampleBound(10, 0.01, 2.33), 1087);   // 1086.224
  EXPECT_EQ(kldSampleBound(10, 0.05, 0.99), 131);    // 130.162 (amcl's defaults)
  EXPECT_EQ(kldSampleBound(100, 0.05, 0.99), 1129);  // 1128.650
}

// KLD-sampling keeps few samples of a cloud gathered in one bin (min_count) and all of one
// spread over many bins (max_count), drawn by weight.
TEST(Resampling, KldKeepsAsManyAsTheCloudsBinsNeed) {
  KldSampling kld;
  kld.min_count = 20;
  kld.max_count = 500;
  kld.error = 0.01;
  kld.z = 2.33;
  std::vector<Pose2> poses;
  for (int i = 0; i < 500; ++i) poses.emplace_back(0.01 * (i % 10), 0.0, 0.0001 * i);
  const std::vector<double> even(500, 1.0 / 500);
  Rng rng(3);
  std::vector<int> drawn = resampleKld(even, poses, kld, rng);
  EXPECT_EQ(drawn.size(), 20u) << "one bin: the minimum";
  // The same count with the cloud spread 1 m apart per particle: every draw a new bin.
  for (int i = 0; i < 500; ++i) poses[i] = Pose2(1.0 * i, 0.0, 0.0);
  drawn = resampleKld(even, poses, kld, rng);
  EXPECT_EQ(drawn.size(), 500u) << "many bins: the maximum";
  // Two bins, one holding all the weight: only its particles are drawn, one bin is occupied.
  std::vector<double> one(500, 0.0);
  one[7] = 1.0;
  drawn = resampleKld(one, poses, kld, rng);
  EXPECT_EQ(drawn.size(), 20u);
  for (int i : drawn) EXPECT_EQ(i, 7);
  // The draws are taken in random order: with the first half of the particles (by index) in
  // one bin and the rest one per bin, draws in index order would stop at min_count in that bin.
  for (int i = 0; i < 500; ++i) poses[i] = i < 250 ? Pose2(0.0, 0.0, 0.0) : Pose2(1.0 * i, 0, 0);
  drawn = resampleKld(even, poses, kld, rng);
  EXPECT_EQ(drawn.size(), 500u) << "taken in index order";
  // Between the two: 3 bins need 463.
  kld.max_count = 1000;
  for (int i = 0; i < 500; ++i) poses[i] = Pose2(0.6 * (i % 3), 0.0, 0.0);
  drawn = resampleKld(even, poses, kld, rng);
  EXPECT_EQ(drawn.size(), 463u);
}

TEST(Resampling, LogWeightsNormaliseAndRecoverFromNaN) {
  std::vector<double> w;
  EXPECT_TRUE(normalizeLogWeights({-1000.0, -1000.0 + std::log(3.0)}, &w));
  EXPECT_NEAR(w[0], 0.25, 1e-12);
  EXPECT_NEAR(w[1], 0.75, 1e-12);
  EXPECT_NEAR(effectiveSampleSize(w), 1.0 / (0.0625 + 0.5625), 1e-12);
  EXPECT_FALSE(normalizeLogWeights({0.0, NAN}, &w));
  EXPECT_DOUBLE_EQ(w[0], 0.5);
  EXPECT_FALSE(normalizeLogWeights({-INFINITY, -INFINITY}, &w));
  EXPECT_DOUBLE_EQ(w[1], 0.5);
}

/// Drives two laps around the room with 3% odometry noise; returns (filter ATE, odom ATE).
std::pair<double, double> runLoop(FilterOptions options, unsigned seed) {
  SyntheticWorld world;
  FastSlam2 filter(options);
  Rng rng(seed);
  std::vector<Pose2> waypoints{{-3, -3, 0}, {3, -3, 0}, {3, 3, 0}, {-3, 3, 0}};
  Pose2 truth(-3, -3, 0), odom = truth;
  filter.reset(truth);
  filter.update(world.observe(truth, rng, 0.02, 0.01));  // anchor the map, as SlamSession does
  double filter_sq = 0, odom_sq = 0;
  int n = 0;
  for (int lap = 0; lap < 2; ++lap) {
    for (size_t w = 1; w <= waypoints.size(); ++w) {
      const Pose2 goal = waypoints[w % waypoints.size()];
      while ((goal.head<2>() - truth.head<2>()).norm() > 0.3) {
        const double heading = std::atan2(goal.y() - truth.y(), goal.x() - truth.x());
        const double turn = std::clamp(wrapAngle(heading - truth.z()), -0.5, 0.5);
        const double step = std::fabs(turn) > 0.3 ? 0.1 : 0.5;
        const Pose2 delta(step, 0.0, turn);
        truth = compose(truth, delta);
        const Pose2 noisy(delta.x() * (1 + sampleGaussian(rng, 0.03)), sampleGaussian(rng, 0.01),
                          delta.z() + sampleGaussian(rng, 0.03 * std::fabs(delta.z()) + 0.01));
        odom = compose(odom, noisy);
        MotionInput motion;
        motion.delta = noisy;
        filter.predict(motion);
        filter.update(world.observe(truth, rng, 0.02, 0.01));
        filter_sq += (filter.estimate().mean.head<2>() - truth.head<2>()).squaredNorm();
        odom_sq += (odom.head<2>() - truth.head<2>()).squaredNorm();
        ++n;
      }
    }
  }
  return {std::sqrt(filter_sq / n), std::sqrt(odom_sq / n)};
}

TEST(FastSlam2, BeatsOdometryOnSyntheticRoom) {
  FilterOptions options;
  options.particles = 30;
  options.seed = 5;
  const auto [filter_ate, odom_ate] = runLoop(options, 11);
  EXPECT_LT(filter_ate, 0.15) << "odometry ATE " << odom_ate;
  EXPECT_LT(filter_ate, 0.5 * odom_ate);
}

TEST(FastSlam2, MapsEveryWallOnceAndIsRepeatable) {
  FilterOptions options;
  options.particles = 20;
  options.seed = 9;
  const auto first = runLoop(options, 3);
  const auto second = runLoop(options, 3);
  EXPECT_DOUBLE_EQ(first.first, second.first);  // same seed, same result
  SyntheticWorld world;
  FastSlam2 filter(options);
  Rng rng(1);
  filter.update(world.observe(Pose2(-3, -3, 0), rng, 0.02, 0.01));
  filter.update(world.observe(Pose2(-3, -3, 0), rng, 0.02, 0.01));
  int lines = 0;
  for (const auto& l : filter.landmarks()) lines += l.type == LandmarkType::kLine;
  EXPECT_EQ(lines, static_cast<int>(world.walls.size()));
}

// FastSLAM estimates whole paths: each particle keeps its history, resampling shares it, and
// bestPath() is the history of the particle whose map landmarks() returns.
TEST(FastSlam2, BestPathIsTheBestParticlesHistory) {
  FilterOptions options;
  options.particles = 20;
  options.seed = 4;
  SyntheticWorld world;
  FastSlam2 filter(options);
  Rng rng(2);
  Pose2 truth(-3, -3, 0), odom = truth;
  filter.reset(truth);
  EXPECT_TRUE(filter.bestPath().empty());
  filter.update(world.observe(truth, rng, 0.02, 0.01));
  std::vector<Pose2> truths{truth}, odoms{odom};
  for (int k = 0; k < 40; ++k) {
    const Pose2 delta(0.15, 0.0, 0.02);
    truth = compose(truth, delta);
    MotionInput motion;
    motion.delta = Pose2(delta.x() * 1.05, 0.01, delta.z() + 0.01);  // biased odometry
    filter.predict(motion);
    filter.update(k % 7 == 3 ? FeatureSet() : world.observe(truth, rng, 0.02, 0.01));
    odom = compose(odom, motion.delta);
    truths.push_back(truth);
    odoms.push_back(odom);
  }
  EXPECT_GT(filter.stats().resamples, 0);
  const std::vector<Pose2> path = filter.bestPath();
  ASSERT_EQ(path.size(), truths.size());  // one pose per update, empty frames included
  const Particle& best = filter.particleSet()[filter.bestParticle()];
  EXPECT_TRUE(path.back().isApprox(best.pose));
  double sq = 0.0, odom_sq = 0.0;
  for (size_t i = 0; i < path.size(); ++i) {
    sq += (path[i].head<2>() - truths[i].head<2>()).squaredNorm();
    odom_sq += (odoms[i].head<2>() - truths[i].head<2>()).squaredNorm();
  }
  EXPECT_LT(std::sqrt(sq / path.size()), 0.5 * std::sqrt(odom_sq / path.size()));
  // Resampled particles share their common history instead of copying it.
  const PathNode* first = filter.particleSet()[0].path.get();
  for (size_t i = 0; i + 5 < path.size(); ++i) first = first->parent.get();
  int shared = 0;
  for (const Particle& p : filter.particleSet()) {
    const PathNode* n = p.path.get();
    for (size_t i = 0; i + 5 < path.size(); ++i) n = n->parent.get();
    shared += n == first;
  }
  EXPECT_GT(shared, 1);
  // bestPathSample picks evenlySpacedPoses' poses through the jump pointers, and the length.
  for (const std::size_t max_poses : {1, 2, 3, 7, 40, 41, 100}) {
    std::size_t length = 0;
    const std::vector<Pose2> sample = filter.bestPathSample(max_poses, &length);
    EXPECT_EQ(length, path.size());
    EXPECT_EQ(sample, evenlySpacedPoses(path, max_poses)) << max_poses << " poses";
  }
  // A new pose distribution starts new paths; a reset forgets them.
  filter.resetPose(truth, Eigen::Matrix3d::Identity() * 0.01);
  EXPECT_TRUE(filter.bestPath().empty());
  filter.update(world.observe(truth, rng, 0.02, 0.01));
  EXPECT_EQ(filter.bestPath().size(), 1u);
  filter.reset(truth);
  EXPECT_TRUE(filter.bestPath().empty());
}

// ancestorAt finds every depth of a long path (and of a branch off it) from any node below it.
TEST(FastSlam2, AncestorAtFindsEveryDepthThroughTheJumps) {
  std::vector<std::shared_ptr<PathNode>> nodes;
  std::shared_ptr<PathNode> tip;
  for (int i = 0; i < 3000; ++i) {
    tip = std::make_shared<PathNode>(Pose2(i, 0, 0), tip);
    nodes.push_back(tip);
  }
  auto branch = std::make_shared<PathNode>(Pose2(-1, 0, 0), nodes[1234]);
  for (int i = 0; i < 100; ++i) branch = std::make_shared<PathNode>(Pose2(-2 - i, 0, 0), branch);
  EXPECT_EQ(branch->depth, 1335u);
  Rng rng(5);
  std::uniform_int_distribution<int> any(0, 2999);
  for (int trial = 0; trial < 2000; ++trial) {
    const int from = any(rng), to = any(rng) % (from + 1);
    const PathNode* found = ancestorAt(nodes[from].get(), to);
    ASSERT_EQ(found, nodes[to].get()) << from << " -> " << to;
    if (to <= 1234) {
      EXPECT_EQ(ancestorAt(branch.get(), to), nodes[to].get());
    }
  }
  EXPECT_EQ(ancestorAt(branch.get(), 1335), branch.get());
  EXPECT_EQ(ancestorAt(branch.get(), 1235)->pose.x(), -1.0);
}

// A live robot updates for hours: freeing a path of millions of poses must not recurse (the
// default shared_ptr chain destruction overflows the stack long before).
TEST(FastSlam2, LongPathIsFreedWithoutRecursion) {
  std::shared_ptr<PathNode> path;
  for (int i = 0; i < 2000000; ++i) path = std::make_shared<PathNode>(Pose2(i, 0, 0), std::move(path));
  std::shared_ptr<PathNode> branch = std::make_shared<PathNode>(Pose2::Zero(), path->parent);
  path.reset();  // the branch still holds all but the newest node
  int length = 0;
  for (const PathNode* n = branch.get(); n != nullptr; n = n->parent.get()) ++length;
  EXPECT_EQ(length, 2000000);
  branch.reset();
  SUCCEED();
}

TEST(FastSlam2, NonFiniteFeaturesAreRejectedNotFused) {
  FilterOptions options;
  options.particles = 5;
  FastSlam2 filter(options);
  FeatureSet set;
  LineFeature bad;
  bad.rho = NAN;
  set.lines.push_back(bad);
  PointFeature inf_point;
  inf_point.range = INFINITY;
  set.points.push_back(inf_point);
  const UpdateStats stats = filter.update(set);
  EXPECT_EQ(stats.features_rejected, 2);
  EXPECT_TRUE(filter.landmarks().empty());
  EXPECT_TRUE(filter.estimate().mean.allFinite());
}

// The step's association counts describe its most probable particle, not whichever particle
// sits first after resampling reordered them.
class TwoMapsFastSlam2 : public FastSlam2 {
 public:
  using FastSlam2::FastSlam2;
  /// Particle i knows one point landmark at `at`.
  void giveLandmark(int i, const Eigen::Vector2d& at) {
    auto map = std::make_shared<LandmarkMap>();
    Landmark lm;
    lm.id = 0;
    lm.mean = at;
    lm.covariance = 1e-4 * Eigen::Matrix2d::Identity();
    map->add(lm);
    particles_[i].map = map;
  }
  void giveSecondParticle(const Eigen::Vector2d& at) { giveLandmark(1, at); }
};

TEST(FastSlam2, KeptMostProbableFindsTheFirstCopyOfTheHeaviest) {
  EXPECT_EQ(keptMostProbable({0, 0, 2, 2, 2}, {0.3, 0.1, 0.6}), 2);
  EXPECT_EQ(keptMostProbable({1, 0, 0}, {0.3, 0.1, 0.6}), 1);  // the heaviest of those kept
  EXPECT_EQ(keptMostProbable({}, {0.3, 0.1, 0.6}), -1);
  // The best particle: the first largest weight, or the resampled best while weights are equal.
  EXPECT_EQ(mostProbable({0.2, 0.4, 0.4}, -1), 1);
  EXPECT_EQ(mostProbable({0.2, 0.4, 0.4}, 0), 1);  // the weights tell: no longer after a resampling
  EXPECT_EQ(mostProbable({0.5, 0.5}, 1), 1);
  EXPECT_EQ(mostProbable({}, 0), -1);
}

// After a resampling every weight is equal: the map and path reported must still be those of
// the particle that was the most probable, not of whichever copy comes first (particle 0's).
TEST(FastSlam2, TheBestParticleAfterResamplingIsACopyOfTheMostProbable) {
  FilterOptions options;
  options.particles = 3;
  options.resample_threshold = 1.0;  // resample at every step
  options.measurement.use_feature_covariance = false;
  options.measurement.sigma_range_m = 0.05;
  TwoMapsFastSlam2 filter(options);
  filter.reset(Pose2::Zero());
  filter.giveLandmark(0, Eigen::Vector2d(5.03, 0.0));  // a little off: less probable
  filter.giveLandmark(1, Eigen::Vector2d(5.0, 0.0));   // exactly where it is seen
  FeatureSet set;
  PointFeature seen;
  seen.range = 5.0;
  seen.bearing = 0.0;
  set.points.push_back(seen);
  ASSERT_TRUE(filter.update(set).resampled);
  const std::vector<LandmarkEstimate> map = filter.landmarks();
  ASSERT_EQ(map.size(), 1u);
  EXPECT_NEAR(map[0].mean.x(), 5.0, 0.01) << "the map of particle 0's copy was reported";
}

TEST(FastSlam2, UpdateStatsDescribeTheMostProbableParticle) {
  FilterOptions options;
  options.particles = 2;
  options.resample_threshold = 1.0;  // resample at every step
  TwoMapsFastSlam2 filter(options);
  filter.reset(Pose2::Zero());
  filter.giveSecondParticle(Eigen::Vector2d(5.0, 0.0));
  FeatureSet set;
  PointFeature seen;  // exactly where particle 1 has its landmark
  seen.range = 5.0;
  seen.bearing = 0.0;
  set.points.push_back(seen);
  const UpdateStats stats = filter.update(set);
  ASSERT_TRUE(stats.resampled);
  EXPECT_EQ(stats.associated, 1) << "particle 1 matched its landmark and outweighs particle 0";
  EXPECT_EQ(stats.new_landmarks, 0);
}

// Data association sampling (association.sample): with two landmarks inside the gate each
// particle draws its match with probability proportional to the match likelihoods, which are
// computed here by hand, and is weighted by their sum; with one landmark in the gate, or with
// sampling off, the step is FastSLAM 2.0's maximum-likelihood one and draws no random number.
class ProposalFastSlam2 : public FastSlam2 {
 public:
  using FastSlam2::FastSlam2;
  ProposalFastSlam2(const FilterOptions& options, std::unique_ptr<EstimatorRule> rule)
      : FastSlam2(options, std::move(rule)) {}
  using FastSlam2::Match;
  using FastSlam2::Proposal;
  using FastSlam2::refineProposal;
  using FastSlam2::updateLandmark;
};

namespace {
/// log N(z; h(pose, landmark), H_pose P H_pose^T + H_lm Sigma H_lm^T + R) at pose (0, 0, 0).
double handMatchLogLikelihood(const Eigen::Vector2d& z, const Eigen::Vector2d& lm,
                              const Eigen::Matrix2d& lm_cov, const Eigen::Matrix3d& pose_cov,
                              const Eigen::Matrix2d& r) {
  const double q = lm.squaredNorm(), d = std::sqrt(q);
  Eigen::Matrix<double, 2, 3> hp;
  hp << -lm.x() / d, -lm.y() / d, 0.0, lm.y() / q, -lm.x() / q, -1.0;
  const Eigen::Matrix2d hl = -hp.leftCols<2>();
  const Eigen::Matrix2d s = hp * pose_cov * hp.transpose() + hl * lm_cov * hl.transpose() + r;
  const Eigen::Vector2d v(z.x() - d, wrapAngle(z.y() - std::atan2(lm.y(), lm.x())));
  return -0.5 * v.dot(s.inverse() * v) - 0.5 * std::log(s.determinant()) - std::log(2 * M_PI);
}
}  // namespace

/// A feature between the gate and the new-landmark threshold is neither matched nor mapped.
/// "none" leaves it out of the weight; "soft" counts its nearest landmark's match likelihood
/// plus the new-landmark likelihood. A feature beyond the threshold counts the latter in both.
TEST(FastSlam2, AmbiguousFeatureWeighsAsMatchOrNewWhenSoft) {
  FilterOptions options;
  options.particles = 1;
  options.association.gate_chi2 = 9.21;
  options.association.new_landmark_chi2 = 20.0;
  const Eigen::Vector2d lm(5.0, 0.0);
  const Eigen::Matrix2d lm_cov = 1e-3 * Eigen::Matrix2d::Identity();
  LandmarkMap map;
  Landmark landmark;
  landmark.id = 0;
  landmark.mean = lm;
  landmark.covariance = lm_cov;
  map.add(landmark);
  const Eigen::Matrix3d pose_cov = Eigen::Vector3d(0.01, 0.01, 0.0004).asDiagonal();
  Observation ambiguous;
  ambiguous.noise = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  ambiguous.z << 5.0, 0.13;  // 0.13 rad off in bearing
  Observation far = ambiguous;
  far.z << 5.0, 0.5;
  const double log_match =
      handMatchLogLikelihood(ambiguous.z, lm, lm_cov, pose_cov, ambiguous.noise);
  // Mahalanobis^2 by hand: at this geometry the innovation covariance is diag(0.021, 0.00124)
  // (pose, landmark and noise) and the innovation (0, 0.13).
  const double d2 = 0.13 * 0.13 / 0.00124;
  ASSERT_GT(d2, 9.21);
  ASSERT_LT(d2, 20.0);
  const double log_new = -0.5 * 20.0 - 0.5 * std::log(ambiguous.noise.determinant()) -
                         std::log(2 * M_PI);

  const ProposalFastSlam2 none(options);
  ProposalFastSlam2::Proposal q = none.refineProposal(map, Pose2::Zero(), pose_cov, {ambiguous});
  EXPECT_TRUE(q.matched.empty());
  EXPECT_TRUE(q.fresh.empty());
  EXPECT_EQ(q.log_likelihood, 0.0);
  q = none.refineProposal(map, Pose2::Zero(), pose_cov, {far});
  ASSERT_EQ(q.fresh.size(), 1u);
  EXPECT_NEAR(q.log_likelihood, log_new, 1e-9);

  options.association.ambiguous_weight = "soft";
  const ProposalFastSlam2 soft(options);
  q = soft.refineProposal(map, Pose2::Zero(), pose_cov, {ambiguous});
  EXPECT_TRUE(q.matched.empty());
  EXPECT_TRUE(q.fresh.empty()) << "an ambiguous feature must not start a landmark";
  EXPECT_NEAR(q.log_likelihood, std::log(std::exp(log_match) + std::exp(log_new)), 1e-9);
  EXPECT_LT(q.log_likelihood, 0.0);
  q = soft.refineProposal(map, Pose2::Zero(), pose_cov, {far});
  ASSERT_EQ(q.fresh.size(), 1u);
  EXPECT_NEAR(q.log_likelihood, log_new, 1e-9);
  EXPECT_NEAR(soft.refineProposal(map, Pose2::Zero(), pose_cov, {ambiguous, far}).log_likelihood,
              std::log(std::exp(log_match) + std::exp(log_new)) + log_new, 1e-9);

  options.association.ambiguous_weight = "new";
  EXPECT_THROW(validate(options), std::invalid_argument);
}

TEST(FastSlam2, SampledAssociationDrawsByLikelihoodAndWeighsByTheirSum) {
  FilterOptions options;
  options.particles = 1;
  const Eigen::Vector2d a(5.0, 0.05), b(5.0, -0.2);  // both within the gate of the sighting
  const Eigen::Matrix2d lm_cov = 1e-3 * Eigen::Matrix2d::Identity();
  LandmarkMap map;
  for (const Eigen::Vector2d& at : {a, b}) {
    Landmark lm;
    lm.id = map.size();
    lm.mean = at;
    lm.covariance = lm_cov;
    map.add(lm);
  }
  const Eigen::Matrix3d pose_cov = Eigen::Vector3d(0.01, 0.01, 0.0004).asDiagonal();
  Observation o;
  o.z << 5.0, 0.0;
  o.noise = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  const double la = handMatchLogLikelihood(o.z, a, lm_cov, pose_cov, o.noise);
  const double lb = handMatchLogLikelihood(o.z, b, lm_cov, pose_cov, o.noise);
  ASSERT_GT(la, lb);
  const double p_a = 1.0 / (1.0 + std::exp(lb - la));
  ASSERT_GT(p_a, 0.55);  // a clear but not certain preference for a
  ASSERT_LT(p_a, 0.95);
  const double sum = la + std::log1p(std::exp(lb - la));

  // Maximum likelihood (sample false, or no generator): always a, weighted by a's likelihood.
  const ProposalFastSlam2 ml(options);
  Rng rng(7);
  const Rng untouched = rng;
  ProposalFastSlam2::Proposal q = ml.refineProposal(map, Pose2::Zero(), pose_cov, {o}, &rng);
  ASSERT_EQ(q.matched.size(), 1u);
  EXPECT_EQ(q.matched[0].second, 0);
  EXPECT_NEAR(q.log_likelihood, la, 1e-9);
  EXPECT_TRUE(rng == untouched) << "sampling off drew a random number";

  options.association.sample = true;
  const ProposalFastSlam2 sampling(options);
  const int draws = 4000;
  int took_a = 0;
  for (int i = 0; i < draws; ++i) {
    q = sampling.refineProposal(map, Pose2::Zero(), pose_cov, {o}, &rng);
    ASSERT_EQ(q.matched.size(), 1u);
    took_a += q.matched[0].second == 0;
    ASSERT_NEAR(q.log_likelihood, sum, 1e-9) << "weight is not the sum of the likelihoods";
  }
  const double sigma = std::sqrt(p_a * (1.0 - p_a) / draws);
  EXPECT_NEAR(static_cast<double>(took_a) / draws, p_a, 4.0 * sigma);
  // sample_weight max: the same draw, weighted by the most likely match as without sampling.
  options.association.sample_weight = "max";
  const ProposalFastSlam2 sampling_max(options);
  options.association.sample_weight = "sum";
  int took_a_max = 0;
  for (int i = 0; i < 400; ++i) {
    q = sampling_max.refineProposal(map, Pose2::Zero(), pose_cov, {o}, &rng);
    took_a_max += q.matched[0].second == 0;
    ASSERT_NEAR(q.log_likelihood, la, 1e-9);
  }
  EXPECT_GT(took_a_max, 200);
  EXPECT_LT(took_a_max, 380) << "max weighs like maximum likelihood but must still sample";
  options.association.sample_weight = "mean";
  EXPECT_THROW(validate(options), std::invalid_argument);
  options.association.sample_weight = "sum";
  // Pointwise weights (H-infinity, Havangi eq. 36) add the drawn match's likelihood at the drawn
  // pose later: the proposal carries only the draw's correction, sum over drawn.
  HinfOptions pointwise;
  pointwise.mode = "relative";
  pointwise.theta_pose = 0.5;
  pointwise.weight = "pointwise";
  const ProposalFastSlam2 sampling_pointwise(options, std::make_unique<HinfRule>(pointwise));
  for (int i = 0; i < 50; ++i) {
    q = sampling_pointwise.refineProposal(map, Pose2::Zero(), pose_cov, {o}, &rng);
    const double drawn = q.matched[0].second == 0 ? la : lb;
    ASSERT_NEAR(q.log_likelihood, sum - drawn, 1e-9);
  }
  // The proposal moves towards the landmark drawn: towards a's bearing when a was taken.
  rng.seed(11);
  for (int i = 0; i < 50; ++i) {
    q = sampling.refineProposal(map, Pose2::Zero(), pose_cov, {o}, &rng);
    const double towards = q.matched[0].second == 0 ? a.y() : b.y();
    EXPECT_GT(q.mean.z() * towards, 0.0) << "heading corrected away from the drawn landmark";
  }

  // One landmark in the gate, or a known identity: FastSLAM 2.0's step, no number drawn.
  LandmarkMap one;
  one.add(map[0]);
  Rng fresh(3);
  const Rng fresh_copy = fresh;
  const ProposalFastSlam2::Proposal single =
      sampling.refineProposal(one, Pose2::Zero(), pose_cov, {o}, &fresh);
  const ProposalFastSlam2::Proposal reference = ml.refineProposal(one, Pose2::Zero(), pose_cov, {o});
  EXPECT_TRUE(fresh == fresh_copy);
  EXPECT_EQ(single.mean, reference.mean);
  EXPECT_EQ(single.cov, reference.cov);
  EXPECT_EQ(single.log_likelihood, reference.log_likelihood);
  Observation known = o;
  known.known_id = 1;
  q = sampling.refineProposal(map, Pose2::Zero(), pose_cov, {known}, &fresh);
  ASSERT_EQ(q.matched.size(), 1u);
  EXPECT_EQ(q.matched[0].second, 1);
  EXPECT_TRUE(fresh == fresh_copy);
}

// measurement.landmark_iterations: a point landmark's update relinearised at the updated mean is
// Gauss-Newton on the prior plus the sighting, so it reaches the MAP estimate, which the one-step
// EKF misses when the range is weak against the bearing; one iteration is the EKF step itself.
TEST(FastSlam2, IteratedLandmarkUpdateReachesTheMapEstimate) {
  const Eigen::Vector2d x0(4.0, 0.0);
  const Eigen::Matrix2d p = 0.09 * Eigen::Matrix2d::Identity();  // 0.3 m each way
  Observation o;
  o.z << 3.5, 0.12;  // shorter and 0.12 rad to the left of the prior mean
  o.noise = Eigen::Vector2d(0.3 * 0.3, 0.005 * 0.005).asDiagonal();
  // The MAP cost: J(x) = (x - x0)^T P^-1 (x - x0) + r(x)^T R^-1 r(x), r = z - h(0, x).
  const auto cost = [&](const Eigen::Vector2d& x) {
    const Eigen::Vector2d r(o.z.x() - x.norm(), wrapAngle(o.z.y() - std::atan2(x.y(), x.x())));
    return (x - x0).dot(p.inverse() * (x - x0)) + r.dot(o.noise.inverse() * r);
  };
  const auto update = [&](int iterations) {
    FilterOptions options;
    options.particles = 1;
    options.measurement.landmark_iterations = iterations;
    ProposalFastSlam2 filter(options);
    LandmarkMap map;
    Landmark lm;
    lm.mean = x0;
    lm.covariance = p;
    map.add(lm);
    ProposalFastSlam2::Match match;
    match.index = 0;
    double ll = 0.0;
    filter.updateLandmark(&map, match, Pose2::Zero(), o, &ll);
    return map[0];
  };
  // One iteration: the EKF step by hand, H the point Jacobian at x0 = (4, 0).
  Eigen::Matrix2d h;
  h << 1.0, 0.0, 0.0, 0.25;
  const Eigen::Matrix2d k = p * h.transpose() * (h * p * h.transpose() + o.noise).inverse();
  const Eigen::Vector2d ekf = x0 + k * (o.z - Eigen::Vector2d(4.0, 0.0));
  const Landmark one = update(1);
  EXPECT_NEAR((one.mean - ekf).norm(), 0.0, 1e-12);
  EXPECT_NEAR((one.covariance - (Eigen::Matrix2d::Identity() - k * h) * p).norm(), 0.0, 1e-12);
  // Ten iterations: a stationary point of J (central differences), and below the EKF's cost.
  const Landmark ten = update(10);
  const double step = 1e-6;
  for (int axis = 0; axis < 2; ++axis) {
    const Eigen::Vector2d e = step * Eigen::Vector2d::Unit(axis);
    const double gradient = (cost(ten.mean + e) - cost(ten.mean - e)) / (2.0 * step);
    EXPECT_NEAR(gradient, 0.0, 1e-3) << "axis " << axis;
  }
  EXPECT_LT(cost(ten.mean), cost(one.mean) - 0.1);
  // The covariance is the last iteration's: (I - K H) P with H at the final linearisation point.
  const double q = ten.mean.squaredNorm(), d = std::sqrt(q);
  Eigen::Matrix2d h10;
  h10 << ten.mean.x() / d, ten.mean.y() / d, -ten.mean.y() / q, ten.mean.x() / q;
  const Eigen::Matrix2d k10 = p * h10.transpose() * (h10 * p * h10.transpose() + o.noise).inverse();
  EXPECT_NEAR((ten.covariance - (Eigen::Matrix2d::Identity() - k10 * h10) * p).norm(), 0.0, 1e-9);
  // The EKF step lands off the sighting's bearing line; the iterated one on it (across the line
  // of sight the bearing, 0.005 rad x 3.5 m, is about 17x tighter than the prior's 0.3 m).
  EXPECT_GT(std::fabs(std::atan2(one.mean.y(), one.mean.x()) - o.z.y()), 0.005);
  EXPECT_LT(std::fabs(std::atan2(ten.mean.y(), ten.mean.x()) - o.z.y()), 0.002);
  FilterOptions bad;
  bad.measurement.landmark_iterations = 0;
  EXPECT_THROW(validate(bad), std::invalid_argument);
}

// association.exclusive: two features of one frame that both fall in the gate of one mapped
// point landmark (and of no other) take it once: the closer fit matches it (the first in the
// frame on a tie), the other starts a new landmark, as two barcodes of a group do when one
// landmark stands for both. Off, both match it.
TEST(FastSlam2, ExclusiveAssociationMatchesALandmarkOncePerFrame) {
  FilterOptions options;
  options.particles = 1;
  options.association.new_landmark_chi2 = options.association.gate_chi2;  // no ambiguous band
  LandmarkMap map;
  Landmark lm;
  lm.mean << 4.0, 0.0;
  lm.covariance = 0.01 * Eigen::Matrix2d::Identity();
  map.add(lm);
  const Eigen::Matrix3d pose_cov = Eigen::Vector3d(1e-4, 1e-4, 1e-5).asDiagonal();
  Observation first, second;
  first.z << 4.0, 0.02;   // 0.08 m to the left of the landmark
  second.z << 4.0, -0.02;  // 0.08 m to the right: 0.16 m between them, one landmark's gate
  first.noise = second.noise = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  const ProposalFastSlam2 plain(options);
  ProposalFastSlam2::Proposal q =
      plain.refineProposal(map, Pose2::Zero(), pose_cov, {first, second});
  ASSERT_EQ(q.matched.size(), 2u) << "both sightings should fall in the landmark's gate";
  EXPECT_EQ(q.matched[0].second, 0);
  EXPECT_EQ(q.matched[1].second, 0);
  EXPECT_TRUE(q.fresh.empty());

  options.association.exclusive = true;
  const ProposalFastSlam2 exclusive(options);
  q = exclusive.refineProposal(map, Pose2::Zero(), pose_cov, {first, second});
  ASSERT_EQ(q.matched.size(), 1u);
  EXPECT_EQ(q.matched[0].first, 0);  // the first feature of the frame keeps the landmark
  EXPECT_EQ(q.matched[0].second, 0);
  EXPECT_EQ(q.fresh, std::vector<int>{1});  // the second is a new landmark
  // The same with sampled association: the taken landmark is not drawn a second time.
  options.association.sample = true;
  const ProposalFastSlam2 sampled(options);
  options.association.sample = false;
  Rng rng(5);
  for (int i = 0; i < 20; ++i) {
    q = sampled.refineProposal(map, Pose2::Zero(), pose_cov, {first, second}, &rng);
    ASSERT_EQ(q.matched.size(), 1u);
    EXPECT_EQ(q.fresh.size(), 1u);
  }

  // The closest fit takes its landmark first, whatever the features' order in the frame: with
  // the landmark at the second sighting, the first feature is the new one.
  map.set(0, [&] { Landmark moved = lm; moved.mean << 4.0, -0.08; return moved; }());
  q = exclusive.refineProposal(map, Pose2::Zero(), pose_cov, {first, second});
  ASSERT_EQ(q.matched.size(), 1u);
  EXPECT_EQ(q.matched[0].first, 1);
  EXPECT_EQ(q.fresh, std::vector<int>{0});

  // A landmark for each sighting: each takes its own (nothing is excluded needlessly).
  Landmark left = lm;
  left.mean << 4.0, 0.08;
  map.add(left);
  q = exclusive.refineProposal(map, Pose2::Zero(), pose_cov, {first, second});
  ASSERT_EQ(q.matched.size(), 2u);
  for (const auto& [feature, landmark] : q.matched) EXPECT_EQ(landmark, feature == 0 ? 1 : 0);
  EXPECT_TRUE(q.fresh.empty());

  // Known identities are matched by id, never excluded; but the landmark a known id took is
  // not offered to an unidentified feature of the frame.
  Observation known_a = first, known_b = second;
  known_a.known_id = known_b.known_id = 5;
  LandmarkMap identified;
  lm.id = 5;
  lm.identified = true;
  identified.add(lm);
  q = exclusive.refineProposal(identified, Pose2::Zero(), pose_cov, {known_a, known_b});
  EXPECT_EQ(q.matched.size(), 2u);
  q = exclusive.refineProposal(identified, Pose2::Zero(), pose_cov, {known_a, second});
  ASSERT_EQ(q.matched.size(), 1u);
  EXPECT_EQ(q.matched[0].first, 0);
  EXPECT_EQ(q.fresh, std::vector<int>{1});
  q = plain.refineProposal(identified, Pose2::Zero(), pose_cov, {known_a, second});
  EXPECT_EQ(q.matched.size(), 2u);
}

// Covariances that are zero, indefinite or asymmetric fall back to the configured noise
// floors; a line given with rho < 0 is the same line as (-rho, theta + pi); thousands of
// features in one frame are taken without harm.
TEST(FastSlam2, DegenerateCovariancesNegativeRhoAndHugeFrames) {
  FilterOptions options;
  options.particles = 5;
  FastSlam2 filter(options);
  FeatureSet set;
  LineFeature zero_cov;
  zero_cov.rho = 2.0;
  zero_cov.theta = 0.0;
  zero_cov.covariance.setZero();
  zero_cov.start << 2.0, -1.0;
  zero_cov.end << 2.0, 1.0;
  set.lines.push_back(zero_cov);
  LineFeature negative_rho = zero_cov;  // the wall y = 3 given as (-3, -pi/2)
  negative_rho.rho = -3.0;
  negative_rho.theta = -M_PI / 2;
  negative_rho.covariance << -1.0, 0.0, 0.0, 0.01;  // indefinite
  negative_rho.start << -1.0, 3.0;
  negative_rho.end << 1.0, 3.0;
  set.lines.push_back(negative_rho);
  PointFeature asymmetric;
  asymmetric.range = 4.0;
  asymmetric.bearing = 1.0;
  asymmetric.covariance << 0.01, 5.0, -5.0, 0.01;
  set.points.push_back(asymmetric);
  const UpdateStats stats = filter.update(set);
  EXPECT_EQ(stats.features_rejected, 0);
  const std::vector<LandmarkEstimate> landmarks = filter.landmarks();
  ASSERT_EQ(landmarks.size(), 3u);
  bool found_y3 = false;
  for (const LandmarkEstimate& lm : landmarks) {
    EXPECT_TRUE(lm.mean.allFinite());
    EXPECT_TRUE(lm.covariance.allFinite());
    EXPECT_GT(lm.covariance.determinant(), 0.0) << "landmark " << lm.id;
    if (lm.type == LandmarkType::kLine && std::fabs(lm.mean.x() - 3.0) < 0.05) {
      found_y3 = std::fabs(wrapAngle(lm.mean.y() - M_PI / 2)) < 0.02;
    }
  }
  std::string seen;
  for (const LandmarkEstimate& lm : landmarks) {
    seen += " (" + std::to_string(lm.mean.x()) + ", " + std::to_string(lm.mean.y()) + ")";
  }
  EXPECT_TRUE(found_y3) << "rho < 0 was not normalised to (3, pi/2):" << seen;

  FeatureSet huge;
  for (int i = 0; i < 20000; ++i) {
    PointFeature p;
    p.range = 1.0 + 0.001 * i;
    p.bearing = -3.0 + 0.0003 * i;
    p.covariance = Eigen::Matrix2d::Identity() * 0.01;
    huge.points.push_back(p);
  }
  MotionInput still;
  filter.predict(still);
  const UpdateStats huge_stats = filter.update(huge);
  EXPECT_EQ(huge_stats.features_in, 20000);
  EXPECT_TRUE(filter.estimate().mean.allFinite());
  EXPECT_TRUE(filter.estimate().covariance.allFinite());
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam
