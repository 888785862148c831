// Robust RBPF-SLAM: the ancestor-set bookkeeping (bounded, spaced, windowed), which set the
// particles come from after a corrupted stretch, and the variant through the factory.

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>

#include "rbpf_slam/core/filters/ancestor_sets.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/filters/robust_fastslam2.h"

namespace rbpf_slam {
namespace core {
namespace {

/// The point feature of a post seen from pose (noise-free, the tests' usual covariance).
PointFeature postSeenFrom(const Pose2& pose, const Eigen::Vector2d& post) {
  const Prediction p = predictPoint(pose, post);
  PointFeature f;
  f.range = p.z.x();
  f.bearing = p.z.y();
  f.covariance = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  return f;
}

AncestorSet setAt(int step, int particles) {
  AncestorSet set;
  set.step = step;
  set.particles.resize(particles);
  set.weights.assign(particles, 1.0 / particles);
  return set;
}

StepRecord recordAt(int step) {
  StepRecord r;
  r.step = step;
  r.motion.delta = Pose2(0.1 * step, 0, 0);
  return r;
}

TEST(AncestorMemory, BoundedSpacedAndWindowed) {
  AncestorMemory memory(/*max_sets=*/3, /*spacing_steps=*/5, /*window_steps=*/20);
  for (int step = 1; step <= 1000; ++step) {
    memory.record(recordAt(step));
    if (memory.canStore(step - 1)) memory.store(setAt(step - 1, 10));
    ASSERT_LE(memory.storedSets(), 3);
    ASSERT_LE(memory.storedRecords(), 20);
  }
  // Sets stored at 0, 5, 10, ...: the latest three are 985, 990, 995.
  const std::vector<const AncestorSet*> usable = memory.usable(1000);
  ASSERT_EQ(usable.size(), 3u);
  EXPECT_EQ(usable[0]->step, 995);
  EXPECT_EQ(usable[1]->step, 990);
  EXPECT_EQ(usable[2]->step, 985);
  // The records a set needs, in order.
  const std::vector<const StepRecord*> records = memory.records(985, 1000);
  ASSERT_EQ(records.size(), 15u);
  EXPECT_EQ(records.front()->step, 986);
  EXPECT_EQ(records.back()->step, 1000);
  EXPECT_DOUBLE_EQ(records.back()->motion.delta.x(), 100.0);
  EXPECT_TRUE(memory.records(900, 1000).empty());  // dropped: beyond the window
}

TEST(AncestorMemory, SetsOutsideTheWindowAreNotUsable) {
  AncestorMemory memory(4, 1, 10);
  for (int step = 1; step <= 3; ++step) memory.record(recordAt(step));
  memory.store(setAt(2, 5));
  for (int step = 4; step <= 12; ++step) memory.record(recordAt(step));
  ASSERT_EQ(memory.usable(12).size(), 1u);  // 12 - 2 = 10 steps: still inside
  memory.record(recordAt(13));
  EXPECT_TRUE(memory.usable(13).empty());
}

TEST(AncestorMemory, TheLatestRecordTakesTheStepsDriftTurn) {
  AncestorMemory memory(2, 1, 10);
  memory.setLatestDriftTurn(0.1);  // no record yet: nothing
  memory.record(recordAt(1));
  memory.record(recordAt(2));
  memory.setLatestDriftTurn(0.05);
  const std::vector<const StepRecord*> records = memory.records(0, 2);
  ASSERT_EQ(records.size(), 2u);
  EXPECT_DOUBLE_EQ(records[0]->drift_turn_rad, 0.0);
  EXPECT_DOUBLE_EQ(records[1]->drift_turn_rad, 0.05);
  EXPECT_DOUBLE_EQ(records[1]->motion.delta.z(), 0.0);  // the odometry itself is kept
}

// A candidate from an older set is moved over the records as the particles of those steps
// were: odometry mean plus each step's drift turn (without the turns it would miss the
// corrections the latest set got).
TEST(AncestorMemory, PropagationAddsTheRecordedDriftTurns) {
  MotionOptions motion;
  const std::unique_ptr<MotionModel> model = createMotionModel(motion);
  StepRecord a = recordAt(1), b = recordAt(2);
  a.motion.delta = Pose2(1.0, 0.0, 0.1);
  b.motion.delta = Pose2(1.0, 0.0, 0.0);
  a.drift_turn_rad = -0.02;
  b.drift_turn_rad = -0.03;
  Pose2 mean = Pose2::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  propagateOverRecords(*model, {&a, &b}, &mean, &cov);
  EXPECT_NEAR(mean.z(), 0.1 - 0.05, 1e-12);
  EXPECT_NEAR(mean.x(), 1.0 + std::cos(0.08), 1e-12);  // the second step after the first turn
  EXPECT_NEAR(mean.y(), std::sin(0.08), 1e-12);
  EXPECT_GT(cov(2, 2), 0.0);
}

TEST(AncestorMemory, SpacingRefusesCloseSets) {
  AncestorMemory memory(4, 5, 100);
  memory.store(setAt(10, 1));
  EXPECT_FALSE(memory.canStore(14));
  memory.store(setAt(14, 1));
  EXPECT_EQ(memory.storedSets(), 1);
  EXPECT_TRUE(memory.canStore(15));
}

// A robot drives along x, 0.2 m per step, with exact odometry:
//   steps 1-10 it sees posts A and B; 11-20 nothing (the tracker forgets them);
//   21-25 it sees A, which has been moved 0.35 m along x: a corrupted observation that pulls
//   every FastSLAM 2.0 particle off; 26-28 nothing; 29-31 it sees B, which has not moved.
// At step 29 the tracker reports B as new, and the robust filter samples from S_28
// (corrupted) and S_20 (stored when A reappeared, before the corruption).
class CorruptedStretch : public ::testing::Test {
 protected:
  static FilterOptions options(const std::string& variant) {
    FilterOptions o;
    o.variant = variant;
    o.particles = 60;
    o.seed = 7;
    o.use_lines = false;
    o.motion.alpha1 = o.motion.alpha2 = o.motion.alpha3 = o.motion.alpha4 = 1e-4;
    o.motion.min_sigma_xy_m = 0.04;
    o.motion.min_sigma_theta_rad = 0.002;
    o.measurement.sigma_range_m = 1e-3;
    o.measurement.sigma_bearing_rad = 1e-3;
    o.robust.ancestor_sets = 3;
    o.robust.ancestor_spacing_steps = 2;
    o.robust.window_steps = 15;
    // One observation at the robust step (B, an old landmark): this scenario is about which set
    // wins, so it allows robust steps on a single old-landmark observation.
    o.robust.min_old_observations = 1;
    o.tracker.forget_after_steps = 5;
    return o;
  }

  /// known_ids: the sensor names its landmarks (a = 0, b = 1, c = 2). only_c: a third landmark
  /// c is first seen with the moved a (steps 22-23, after S_20 was stored) and is the only one
  /// seen at steps 29-31, instead of b.
  static double run(SlamFilter* filter, bool known_ids = false, bool only_c = false) {
    const Eigen::Vector2d a(8.0, 0.5), b(9.0, -0.5), c(9.5, 1.5);
    const Eigen::Vector2d moved_a = a + Eigen::Vector2d(0.35, 0.0);
    Pose2 truth = Pose2::Zero();
    for (int step = 1; step <= 31; ++step) {
      MotionInput motion;
      motion.dt = 0.2;
      motion.delta = Pose2(0.2, 0, 0);
      truth = compose(truth, motion.delta);
      filter->predict(motion);
      FeatureSet features;
      auto see = [&](const Eigen::Vector2d& landmark, int id) {
        PointFeature f;
        if (known_ids) f.id = id;
        const Prediction p = predictPoint(truth, landmark);
        f.range = p.z.x();
        f.bearing = p.z.y();
        f.covariance = Eigen::Vector2d(0.0025, 0.0001).asDiagonal();
        features.points.push_back(f);
      };
      if (step <= 10) {
        see(a, 0);
        see(b, 1);
      } else if (step >= 21 && step <= 25) {
        see(moved_a, 0);
        if (only_c && step >= 22 && step <= 23) see(c, 2);
      } else if (step >= 29) {
        if (only_c) {
          see(c, 2);
        } else {
          see(b, 1);
        }
      }
      filter->update(features);
    }
    return (filter->estimate().mean.head<2>() - truth.head<2>()).norm();
  }
};

TEST_F(CorruptedStretch, ParticlesComeFromTheSetBeforeTheCorruption) {
  RobustFastSlam2 robust(options("robust_fastslam2"));
  const double robust_error = run(&robust);
  auto plain = createFilter(options("fastslam2"));
  const double plain_error = run(plain.get());
  std::map<int, int> by_origin;
  for (int origin : robust.origins()) ++by_origin[origin];
  ASSERT_EQ(static_cast<int>(robust.origins().size()), 60);
  // Every particle names a set that existed: S_28 or a stored one.
  for (const auto& [step, count] : by_origin) {
    EXPECT_TRUE(step == 28 || step == 20) << "origin step " << step << " x" << count;
  }
  EXPECT_GT(by_origin[20], 40) << "most particles should come from S_20";
  EXPECT_GE(robust.stats().robust_steps, 1);
  EXPECT_GT(robust.robustStats().replayed_steps, 0);
  EXPECT_GT(plain_error, 0.08) << "the scenario must corrupt FastSLAM 2.0";
  EXPECT_LT(robust_error, 0.5 * plain_error) << robust_error << " vs " << plain_error;
}

// Whether an observation is evidence every ancestor set can weigh (a landmark mapped before the
// oldest set) must not depend on the sensor naming its landmarks. At steps 29-31 only c is
// seen, first mapped at step 22, after the oldest set: no old-landmark evidence, so those events
// are plain FastSLAM 2.0 steps (min_old_observations 1), with known ids as without them.
TEST_F(CorruptedStretch, KnownIdsDoNotMakeNewerLandmarksOldEvidence) {
  RobustFastSlam2 unnamed(options("robust_fastslam2"));
  run(&unnamed, false, true);
  RobustFastSlam2 named(options("robust_fastslam2"));
  run(&named, true, true);
  EXPECT_GE(unnamed.robustStats().fallbacks, 1)
      << "the scenario must reach the decision: events " << unnamed.robustStats().tracker_events
      << ", robust steps " << unnamed.stats().robust_steps;
  EXPECT_EQ(named.stats().robust_steps, unnamed.stats().robust_steps);
  EXPECT_EQ(named.robustStats().fallbacks, unnamed.robustStats().fallbacks);
}

// The moved post A is seen at steps 21-25. A particle kept from S_20 gets those observations in
// the replay (section IV), where A no longer matches and becomes a new landmark. It is stamped
// with the robust step (29), when the kept particle learnt it, so that later events treat it as
// newer than their ancestor sets (oldLandmarkObservations). A review proposed the stored steps
// (21-25, as in the lineages that saw it live); measured worse on 20 seeds (docs/results.md,
// session 14), so this is deliberate and guarded here.
TEST_F(CorruptedStretch, ReplayedLandmarksCountAsLearntAtTheRobustStep) {
  struct Inspected : RobustFastSlam2 {
    using RobustFastSlam2::RobustFastSlam2;
    const Particle& particle(int i) const { return particles_[i]; }
  };
  Inspected robust(options("robust_fastslam2"));
  run(&robust);
  int replayed = 0, mapped_moved_post = 0;
  for (int i = 0; i < static_cast<int>(robust.origins().size()); ++i) {
    if (robust.origins()[i] != 20) continue;  // kept from S_20: steps 21-28 were replayed
    ++replayed;
    // Posts A and B are mapped at step 1; any other landmark comes from the moved A.
    const LandmarkMap& map = *robust.particle(i).map;
    for (int j = 0; j < map.size(); ++j) {
      if (map[j].created_step == 1) continue;
      ++mapped_moved_post;
      EXPECT_GE(map[j].created_step, 29) << "particle " << i;
    }
  }
  EXPECT_GT(replayed, 30) << "the scenario must keep particles from S_20";
  EXPECT_GT(mapped_moved_post, replayed / 2) << "the replays must map the moved post";
}

// A particle kept from an older set skipped the steps since that set: its path gets them from
// the intermediate path (sampled in the replay, or the estimated means without it), so the best
// particle's path has one pose per update and no jump, like FastSLAM 2.0's, and offline_slam
// can write it as the trajectory (it falls back to the online estimate on a length mismatch).
TEST_F(CorruptedStretch, KeptParticlesHaveOnePosePerUpdate) {
  for (const bool replay : {true, false}) {
    FilterOptions o = options("robust_fastslam2");
    o.robust.intermediate_path = replay;
    RobustFastSlam2 robust(o);
    run(&robust);
    std::map<int, int> by_origin;
    for (int origin : robust.origins()) ++by_origin[origin];
    ASSERT_GT(by_origin[20], 0) << "the scenario must keep particles from the older set";
    const std::vector<Pose2> path = robust.bestPath();
    ASSERT_EQ(path.size(), 31u) << "replay " << replay;
    for (size_t k = 1; k < path.size(); ++k) {
      const double stride = (path[k].head<2>() - path[k - 1].head<2>()).norm();
      EXPECT_LT(stride, 0.5) << "step " << k + 1 << ", replay " << replay;
    }
    // Exact odometry along x: the path stays near the truth x = 0.2 step, skipped steps too.
    for (size_t k = 0; k < path.size(); ++k) {
      EXPECT_NEAR(path[k].x(), 0.2 * (k + 1), 0.5) << "step " << k + 1 << ", replay " << replay;
    }
  }
}

TEST_F(CorruptedStretch, MemoryStaysBoundedOverALongRun) {
  FilterOptions o = options("robust_fastslam2");
  o.particles = 10;
  o.robust.min_old_observations = 0;  // only new posts in view: robust steps all the same
  RobustFastSlam2 robust(o);
  for (int step = 1; step <= 600; ++step) {
    MotionInput motion;
    motion.delta = Pose2(0.2, 0, 0.01);
    robust.predict(motion);
    FeatureSet features;
    PointFeature f;  // a new post every 8 steps, 2 m ahead
    f.range = 2.0;
    f.bearing = 0.3 * ((step / 8) % 3) - 0.3;
    f.covariance = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
    if (step % 8 < 4) features.points.push_back(f);
    robust.update(features);
    ASSERT_LE(robust.memory().storedSets(), o.robust.ancestor_sets - 1);
    ASSERT_LE(robust.memory().storedRecords(), o.robust.window_steps);
    ASSERT_LE(robust.tracker().trackedLandmarks(), o.tracker.max_landmarks);
  }
  EXPECT_GT(robust.stats().robust_steps, 10);
}

// Drives 0.2 m per step past posts at (3 k, +-2), each seen for a few steps: tracker events.
void drivePastPosts(SlamFilter* filter, int steps) {
  Pose2 truth = Pose2::Zero();
  for (int step = 1; step <= steps; ++step) {
    MotionInput motion;
    motion.delta = Pose2(0.2, 0, 0);
    truth = compose(truth, motion.delta);
    filter->predict(motion);
    FeatureSet features;
    for (int k = 1; k <= 20; ++k) {
      const Eigen::Vector2d post(3.0 * k, k % 2 == 0 ? 2.0 : -2.0);
      const PointFeature f = postSeenFrom(truth, post);
      if (f.range > 4.0 || std::fabs(f.bearing) > M_PI / 2) continue;
      features.points.push_back(f);
    }
    filter->update(features);
  }
}

FilterOptions postOptions() {
  FilterOptions o;
  o.variant = "robust_fastslam2";
  o.particles = 20;
  o.use_lines = false;
  o.robust.ancestor_sets = 3;
  o.robust.ancestor_spacing_steps = 2;
  o.robust.window_steps = 40;
  o.robust.min_old_observations = 0;  // one or two posts in view: robust steps all the same
  return o;
}

TEST(RobustFastSlam2, NewPoseOrMapForgetsTheStoredSets) {
  RobustFastSlam2 robust(postOptions());
  drivePastPosts(&robust, 60);
  ASSERT_GT(robust.memory().storedSets(), 0);
  ASSERT_GT(robust.stats().robust_steps, 0);
  ASSERT_TRUE(robust.resetPose(Pose2(1, 2, 0.3), Eigen::Matrix3d::Identity() * 1e-4));
  EXPECT_EQ(robust.memory().storedSets(), 0);
  EXPECT_EQ(robust.memory().storedRecords(), 0);
  EXPECT_EQ(robust.tracker().trackedLandmarks(), 0);
  drivePastPosts(&robust, 30);
  ASSERT_GT(robust.memory().storedSets(), 0);
  ASSERT_TRUE(robust.loadMap(robust.landmarks()));
  EXPECT_EQ(robust.memory().storedSets(), 0);
}

TEST(RobustFastSlam2, LocalizationOnlyLeavesTheMapAlone) {
  RobustFastSlam2 mapper(postOptions());
  drivePastPosts(&mapper, 80);
  const std::vector<LandmarkEstimate> map = mapper.landmarks();
  ASSERT_GE(map.size(), 4u);
  RobustFastSlam2 robust(postOptions());
  ASSERT_TRUE(robust.loadMap(map));
  ASSERT_TRUE(robust.setMapping(false));
  drivePastPosts(&robust, 80);
  EXPECT_GT(robust.stats().robust_steps, 0);
  const std::vector<LandmarkEstimate> after = robust.landmarks();
  ASSERT_EQ(after.size(), map.size());
  for (size_t i = 0; i < map.size(); ++i) {
    EXPECT_EQ(after[i].id, map[i].id);
    EXPECT_TRUE(after[i].mean.isApprox(map[i].mean, 1e-12)) << i;
  }
}

TEST(RobustFastSlam2, FactoryAndValidation) {
  FilterOptions o;
  o.variant = "robust_fastslam2";
  auto filter = createFilter(o);
  EXPECT_EQ(filter->variant(), "robust_fastslam2");
  o.robust.ancestor_sets = 0;
  try {
    createFilter(o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("robust.ancestor_sets"), std::string::npos);
  }
  o = FilterOptions();
  o.tracker.max_landmarks = 0;
  EXPECT_THROW(createFilter(o), std::invalid_argument);
}

// With K = 1 there is no older set: the robust variant is FastSLAM 2.0, draw for draw.
TEST(RobustFastSlam2, OneSetIsFastSlam2) {
  FilterOptions o;
  o.particles = 20;
  o.use_lines = false;
  o.robust.ancestor_sets = 1;
  o.variant = "robust_fastslam2";
  auto robust = createFilter(o);
  o.variant = "fastslam2";
  auto plain = createFilter(o);
  for (int step = 1; step <= 40; ++step) {
    MotionInput motion;
    motion.delta = Pose2(0.1, 0.0, 0.02);
    FeatureSet features;
    PointFeature f;
    f.range = 3.0 + 0.01 * step;
    f.bearing = 0.2 - 0.01 * step;
    f.covariance = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
    features.points.push_back(f);
    for (SlamFilter* filter : {robust.get(), plain.get()}) {
      filter->predict(motion);
      filter->update(features);
    }
  }
  EXPECT_TRUE(robust->estimate().mean.isApprox(plain->estimate().mean, 1e-12));
  EXPECT_EQ(robust->landmarks().size(), plain->landmarks().size());
}

// A sparse sensor (the paper's sonar; lee_sim_b_short): at most one post in view, each seen for
// a few steps and then never again, so at every tracker event the only observation is of a
// landmark no ancestor set knows. z_t cannot weigh the candidates, and robust steps used to keep
// about (K - 1) / K of them from older sets by their odometry spread alone (docs/results.md,
// session 6b: the estimate diverged in lee_sim_b_short). Such events now take FastSLAM 2.0's
// step: the filter is FastSLAM 2.0 draw for draw over the whole run.
void driveSparse(SlamFilter* filter, int steps) {
  Pose2 truth = Pose2::Zero();
  for (int step = 1; step <= steps; ++step) {
    MotionInput motion;
    motion.dt = 0.2;
    motion.delta = Pose2(0.2, 0.0, 0.01);
    truth = compose(truth, motion.delta);
    filter->predict(motion);
    FeatureSet features;
    if (step % 8 < 4) {  // a new post, 2 m ahead, for 4 steps out of 8
      const Pose2 first = compose(truth, Pose2(-0.2 * (step % 8), 0.0, -0.01 * (step % 8)));
      const Eigen::Vector2d post = transformPoint(first, Eigen::Vector2d(2.0, 0.5));
      features.points.push_back(postSeenFrom(truth, post));
    }
    filter->update(features);
  }
}

TEST(RobustFastSlam2, SparseEventsTakeFastSlam2Steps) {
  FilterOptions o = postOptions();
  o.robust.window_steps = 25;
  o.robust.min_old_observations = FilterOptions().robust.min_old_observations;
  ASSERT_GE(o.robust.min_old_observations, 1);  // the shipped default falls back
  o.variant = "fastslam2";
  auto plain = createFilter(o);
  driveSparse(plain.get(), 120);
  o.variant = "robust_fastslam2";
  RobustFastSlam2 robust(o);
  driveSparse(&robust, 120);
  EXPECT_GT(robust.robustStats().tracker_events, 10);
  EXPECT_GT(robust.robustStats().fallbacks, 10);
  EXPECT_EQ(robust.stats().robust_steps, 0);
  EXPECT_EQ(robust.robustStats().from_older_sets, 0);
  EXPECT_TRUE(robust.estimate().mean.isApprox(plain->estimate().mean, 1e-12))
      << robust.estimate().mean.transpose() << " vs " << plain->estimate().mean.transpose();
  EXPECT_EQ(robust.landmarks().size(), plain->landmarks().size());
  // The behaviour before: without the fallback the same stream takes robust steps that keep
  // particles from older sets, and the filter leaves FastSLAM 2.0.
  o.robust.min_old_observations = 0;
  RobustFastSlam2 unguarded(o);
  driveSparse(&unguarded, 120);
  EXPECT_GT(unguarded.stats().robust_steps, 5);
  EXPECT_GT(unguarded.robustStats().from_older_sets, 0);
  EXPECT_EQ(unguarded.robustStats().fallbacks, 0);
  EXPECT_FALSE(unguarded.estimate().mean.isApprox(plain->estimate().mean, 1e-12));
}

// Enough old landmarks in view (three posts seen since the start, and a new one every 6 steps):
// the events are robust steps, not fallbacks.
TEST(RobustFastSlam2, EventsWithOldLandmarksInViewAreRobustSteps) {
  FilterOptions o = postOptions();
  o.robust.window_steps = 25;
  o.robust.min_old_observations = 3;
  RobustFastSlam2 robust(o);
  const std::vector<Eigen::Vector2d> old_posts{{6.0, 2.0}, {7.0, -2.0}, {9.0, 1.0}};
  Pose2 truth = Pose2::Zero();
  for (int step = 1; step <= 80; ++step) {
    MotionInput motion;
    motion.dt = 0.2;
    motion.delta = Pose2(0.1, 0.0, 0.0);
    truth = compose(truth, motion.delta);
    robust.predict(motion);
    FeatureSet features;
    std::vector<Eigen::Vector2d> posts = old_posts;
    if (step % 6 == 0) posts.emplace_back(truth.x() + 2.0, -0.5 - 0.1 * step);  // new, once
    for (const Eigen::Vector2d& post : posts) {
      features.points.push_back(postSeenFrom(truth, post));
    }
    robust.update(features);
  }
  // Only the first events fall back: their oldest set predates the posts.
  EXPECT_GE(robust.stats().robust_steps, 3);
  EXPECT_GT(robust.stats().robust_steps, robust.robustStats().fallbacks);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam
