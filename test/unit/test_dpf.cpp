// Distributed particle filter (Pei et al. 2014): the adaptive covariance of eq. 13 and the
// master's fusion weights on hand cases, fault isolation and re-initialisation, determinism
// across thread counts, and accuracy against FastSLAM 2.0 on a synthetic landmark world.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "rbpf_slam/core/filters/distributed_filter.h"
#include "rbpf_slam/core/filters/dpf_local_filter.h"
#include "rbpf_slam/core/filters/dpf_master.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/grid/grid_map_data.h"
#include "rbpf_slam/io/slam_config.h"

namespace rbpf_slam {
namespace core {
namespace {

TEST(DpfAdaptiveCovariance, AddsTheWeightedSpreadOfTheInnovations) {
  const Eigen::Matrix2d r = Eigen::Vector2d(0.01, 0.001).asDiagonal();
  // Two particles, equal weights, innovations +-1 m in range: spread diag(1, 0).
  Eigen::Matrix2d c = adaptiveLikelihoodCovariance({{1.0, 0.0}, {-1.0, 0.0}}, {0.5, 0.5}, r);
  EXPECT_NEAR(c(0, 0), 1.01, 1e-12);
  EXPECT_NEAR(c(1, 1), 0.001, 1e-12);
  EXPECT_NEAR(c(0, 1), 0.0, 1e-12);
  // Unequal weights: mean 0.5 (range), spread 0.25 * 1.5^2 + 0.75 * 0.5^2 = 0.75; bearing
  // innovations 0.2 and 0: mean 0.05, spread 0.25 * 0.15^2 + 0.75 * 0.05^2 = 0.0075; cross
  // 0.25 * 1.5 * 0.15 + 0.75 * (-0.5) * (-0.05) = 0.075.
  c = adaptiveLikelihoodCovariance({{2.0, 0.2}, {0.0, 0.0}}, {0.25, 0.75}, r);
  EXPECT_NEAR(c(0, 0), 0.76, 1e-12);
  EXPECT_NEAR(c(1, 1), 0.0085, 1e-12);
  EXPECT_NEAR(c(0, 1), 0.075, 1e-12);
  EXPECT_NEAR(c(1, 0), 0.075, 1e-12);
  // Collapsed particles: the measurement noise alone.
  c = adaptiveLikelihoodCovariance({{0.3, 0.1}, {0.3, 0.1}}, {0.5, 0.5}, r);
  EXPECT_TRUE(c.isApprox(r));
}

TEST(DpfFeedback, LogRatioIsTheGaussianOfTheOtherLocalsInformation) {
  // Own posterior N(0, I), master N(m, I / 4): the ratio has information 4 - 1 = 3 and centre
  // 4 m / 3 in every direction (x, y, heading).
  const Pose2 m(0.3, -0.6, 0.15);
  const Pose2 centre = m * (4.0 / 3.0);
  const std::vector<Pose2> poses = {centre, centre + Pose2(0.5, 0.0, 0.0),
                                    centre + Pose2(0.0, -0.2, 0.1)};
  const std::vector<double> r = feedbackLogRatio(poses, m, 0.25 * Eigen::Matrix3d::Identity(),
                                                 Pose2::Zero(), Eigen::Matrix3d::Identity());
  EXPECT_NEAR(r[0], 0.0, 1e-6);
  EXPECT_NEAR(r[1] - r[0], -0.5 * 3.0 * 0.25, 1e-6);
  EXPECT_NEAR(r[2] - r[0], -0.5 * 3.0 * (0.04 + 0.01), 1e-6);
}

TEST(DpfFeedback, LogRatioLeavesOutDirectionsWhereTheMasterIsBroader) {
  // The master is sharper in x only (0.25 against 1) and broader in y and heading: only x
  // weighs the particles; y and the heading change nothing.
  const Eigen::Matrix3d master = Eigen::Vector3d(0.25, 4.0, 4.0).asDiagonal();
  const std::vector<Pose2> poses = {Pose2(0.0, 0.0, 0.0), Pose2(0.0, 3.0, -1.0),
                                    Pose2(1.0, 0.0, 0.0)};
  const std::vector<double> r =
      feedbackLogRatio(poses, Pose2::Zero(), master, Pose2::Zero(), Eigen::Matrix3d::Identity());
  EXPECT_NEAR(r[1] - r[0], 0.0, 1e-9);
  EXPECT_NEAR(r[2] - r[0], -0.5 * 3.0, 1e-6);
  // Headings are compared wrapped around the master's.
  const std::vector<double> w =
      feedbackLogRatio({Pose2(0.0, 0.0, M_PI - 0.1), Pose2(0.0, 0.0, -M_PI + 0.1)},
                       Pose2(0.0, 0.0, M_PI), 0.25 * Eigen::Matrix3d::Identity(),
                       Pose2(0.0, 0.0, M_PI), Eigen::Matrix3d::Identity());
  EXPECT_NEAR(w[0], w[1], 1e-9);
}

TEST(DpfMasterWeights, InnovationNeffAndMixedOnHandCases) {
  const auto inn = innovationWeights({2.0, 4.0});
  EXPECT_NEAR(inn[0], 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(inn[1], 1.0 / 3.0, 1e-12);
  const auto neff = neffWeights({0.8, 0.2});
  EXPECT_NEAR(neff[0], 0.8, 1e-12);
  EXPECT_NEAR(neff[1], 0.2, 1e-12);
  const auto mixed = mixedWeights(inn, neff, 0.5);
  EXPECT_NEAR(mixed[0], (2.0 / 3.0 + 0.8) / 2.0, 1e-12);
  EXPECT_NEAR(mixed[1], (1.0 / 3.0 + 0.2) / 2.0, 1e-12);
  const auto inn_only = mixedWeights(inn, neff, 1.0);
  EXPECT_NEAR(inn_only[0], inn[0], 1e-12);
  // Degenerate inputs: all zero -> uniform; NaN counts as zero.
  const auto zero = neffWeights({0.0, 0.0, 0.0, 0.0});
  for (double w : zero) EXPECT_DOUBLE_EQ(w, 0.25);
  const auto nan = neffWeights({NAN, 1.0});
  EXPECT_DOUBLE_EQ(nan[0], 0.0);
  EXPECT_DOUBLE_EQ(nan[1], 1.0);
}

DpfLocalEstimate estimateOf(int index, long step, const Pose2& mean, double nis, double neff) {
  DpfLocalEstimate e;
  e.index = index;
  e.step = step;
  e.mean = mean;
  e.covariance = Eigen::Matrix3d::Identity() * 0.01;
  e.particles = 100;
  e.neff = neff * 100;
  e.innovations = 2;
  e.nis_sum = 2 * nis;
  return e;
}

TEST(DpfMaster, FusesWithTheConfiguredWeights) {
  for (const std::string weighting : {"innovation", "neff", "mixed"}) {
    DpfOptions o;
    o.local_filters = 2;
    o.weighting = weighting;
    o.fusion = "average";
    o.innovation_smoothing = 1.0;  // this step's NIS only
    o.fault_nis = 1e9;
    o.fault_neff_ratio = 0.0;
    DpfMaster master(o);
    const auto out = master.fuse(1, MotionInput(), {estimateOf(1, 1, Pose2(1.0, 0.0, 0.0), 4.0, 0.2),
                                     estimateOf(0, 1, Pose2(0.0, 0.0, 0.0), 2.0, 0.8)});
    const double expected = weighting == "innovation" ? 1.0 / 3.0
                            : weighting == "neff"     ? 0.2
                                                      : (1.0 / 3.0 + 0.2) / 2.0;
    EXPECT_NEAR(out.weights[1], expected, 1e-12) << weighting;
    EXPECT_NEAR(out.mean.x(), expected, 1e-12) << weighting;  // weighted mean of 0 and 1
    EXPECT_TRUE(out.feedback.reinitialise.empty());
  }
}

TEST(DpfMaster, DownWeightsThenIsolatesAFaultyLocalAndNamesAMissingOne) {
  DpfOptions o;
  o.local_filters = 3;
  o.isolate_after_steps = 3;
  o.fusion = "average";
  o.fault_prior_chi2 = 0.0;  // these estimates carry no priors: the NIS / Neff checks alone
  DpfMaster master(o);
  const Pose2 good(5.0, 5.0, 0.1), bad(9.0, 1.0, 1.0);
  for (long step = 1; step <= 3; ++step) {
    const auto out = master.fuse(step, MotionInput(), {estimateOf(0, step, good, 2.0, 0.9),
                                        estimateOf(1, step, bad, 200.0, 0.9),
                                        estimateOf(2, step, good, 2.0, 0.9)});
    EXPECT_TRUE(master.health()[1].suspect);
    EXPECT_FALSE(master.health()[0].suspect);
    if (step < 3) {
      EXPECT_GT(out.weights[1], 0.0);
      EXPECT_LT(out.weights[1], 0.05);
      EXPECT_TRUE(out.feedback.reinitialise.empty());
    } else {
      EXPECT_EQ(out.weights[1], 0.0);
      ASSERT_EQ(out.feedback.reinitialise.size(), 1u);
      EXPECT_EQ(out.feedback.reinitialise[0], 1);
      EXPECT_TRUE(out.mean.isApprox(good, 1e-12));
      EXPECT_EQ(master.health()[1].isolations, 1);
    }
  }
  // With every local isolated at once (here the only one), none may be fused: the master keeps
  // its prediction (the last estimate, the zero pose, moved by a zero step).
  for (const std::string fusion : {"average", "information"}) {
    DpfOptions lone = o;
    lone.local_filters = 1;
    lone.isolate_after_steps = 1;
    lone.fusion = fusion;
    DpfMaster single(lone);
    const auto out = single.fuse(1, MotionInput(), {estimateOf(0, 1, bad, 200.0, 0.9)});
    EXPECT_EQ(single.health()[0].isolations, 1) << fusion;
    EXPECT_LT(out.mean.head<2>().norm(), 1e-9) << fusion << ": the isolated local was fused";
    EXPECT_TRUE(out.mean.allFinite() && out.covariance.allFinite()) << fusion;
  }
  // Neff-only weighting watches Neff: a collapsed local filter is flagged there.
  o.weighting = "neff";
  DpfMaster neff_master(o);
  neff_master.fuse(1, MotionInput(), {estimateOf(0, 1, good, 2.0, 0.9), estimateOf(1, 1, bad, 2.0, 0.001),
                       estimateOf(2, 1, good, 2.0, 0.9)});
  EXPECT_TRUE(neff_master.health()[1].suspect);
  try {
    master.fuse(4, MotionInput(), {estimateOf(0, 4, good, 2.0, 0.9), estimateOf(2, 4, good, 2.0, 0.9)});
    FAIL() << "a missing estimate must be an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("local filter 1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(master.fuse(5, MotionInput(), {estimateOf(0, 5, good, 2, 1), estimateOf(1, 4, good, 2, 1),
                               estimateOf(2, 5, good, 2, 1)}),
               std::invalid_argument);
}

TEST(DpfMaster, InformationFusionAddsWhatEachLocalLearned) {
  // Prior N(0, I) for both; local 0 learned x = 1 with information I (posterior 0.5 I at
  // (1, 0, 0)), local 1 learned y = 1 likewise. A centralised Kalman update with both gives
  // information 3 I and mean (2/3, 2/3, 0).
  DpfOptions o;
  o.local_filters = 2;
  DpfMaster master(o);
  DpfLocalEstimate a = estimateOf(0, 1, Pose2(1.0, 0.0, 0.0), 2.0, 0.9);
  DpfLocalEstimate b = estimateOf(1, 1, Pose2(0.0, 1.0, 0.0), 2.0, 0.9);
  for (DpfLocalEstimate* e : {&a, &b}) {
    e->prior_mean = Pose2::Zero();
    e->prior_covariance = Eigen::Matrix3d::Identity();
    e->covariance = 0.5 * Eigen::Matrix3d::Identity();
  }
  auto out = master.fuse(1, MotionInput(), {a, b});
  EXPECT_NEAR(out.mean.x(), 2.0 / 3.0, 1e-6);
  EXPECT_NEAR(out.mean.y(), 2.0 / 3.0, 1e-6);
  EXPECT_NEAR(out.mean.z(), 0.0, 1e-6);
  EXPECT_TRUE(out.covariance.isApprox(Eigen::Matrix3d::Identity() / 3.0, 1e-6));
  // A local filter trusted half as much (weight 1/4 of 2: trust 0.5) contributes half of it.
  b.nis_sum = 2 * 6.0;  // mean NIS 6 vs 2: innovation weight 1/4
  o.weighting = "innovation";
  o.innovation_smoothing = 1.0;
  DpfMaster by_innovation(o);
  out = by_innovation.fuse(1, MotionInput(), {a, b});
  EXPECT_NEAR(out.weights[1], 0.25, 1e-9);
  // Trust: local 0 min(1, 2 * 0.75) = 1, local 1 min(1, 2 * 0.25) = 0.5. Information
  // I + I + 0.5 I = 2.5 I, vector (2, 0, 0) + 0.5 (0, 2, 0): mean (0.8, 0.4, 0).
  EXPECT_NEAR(out.mean.x(), 0.8, 1e-6);
  EXPECT_NEAR(out.mean.y(), 0.4, 1e-6);
  EXPECT_TRUE(out.covariance.isApprox(Eigen::Matrix3d::Identity() / 2.5, 1e-6));
}

TEST(DpfMaster, GainedInformationKeepsOnlyTheDirectionsWithAGain) {
  // Gain diag(3, -1, 0): only x was learned. The vector's y and heading components are not
  // information (with the clipped gain ~0 there they would move the estimate without bound).
  Eigen::Matrix3d information, not_gained;
  Eigen::Vector3d vector;
  gainedInformation(Eigen::Vector3d(4.0, 1.0, 1.0).asDiagonal(),
                    Eigen::Vector3d(1.0, 2.0, 1.0).asDiagonal(), Eigen::Vector3d(3.0, 5.0, 7.0),
                    &information, &vector, &not_gained);
  EXPECT_TRUE(not_gained.isApprox(Eigen::Vector3d(0.0, 1.0, 1.0).asDiagonal().toDenseMatrix(),
                                  1e-12))
      << not_gained;
  EXPECT_TRUE(information.isApprox(Eigen::Vector3d(3.0, 0.0, 0.0).asDiagonal().toDenseMatrix(),
                                   1e-12))
      << information;
  EXPECT_NEAR(vector.x(), 3.0, 1e-12);
  EXPECT_NEAR(vector.y(), 0.0, 1e-12);
  EXPECT_NEAR(vector.z(), 0.0, 1e-12);
}

TEST(DpfMaster, WhereALocalGainedNoInformationTheMasterTakesItsMeanMoveTimesItsWeight) {
  // Local 0: prior N(0, I); posterior at (1, 0.5, 0) with covariance diag(0.5, 2, 1): it
  // learned x (information 1 -> 2, i.e. measured x = 2) but its cloud widened along y while its
  // weighting moved it 0.5 m. Local 1 saw nothing. Both weigh 0.5.
  DpfOptions o;
  o.local_filters = 2;
  DpfMaster master(o);
  DpfLocalEstimate a = estimateOf(0, 1, Pose2(1.0, 0.5, 0.0), 2.0, 0.9);
  DpfLocalEstimate b = estimateOf(1, 1, Pose2::Zero(), 2.0, 0.9);
  b.innovations = 0;
  b.nis_sum = 0.0;
  for (DpfLocalEstimate* e : {&a, &b}) {
    e->prior_mean = Pose2::Zero();
    e->prior_covariance = Eigen::Matrix3d::Identity();
  }
  a.covariance = Eigen::Vector3d(0.5, 2.0, 1.0).asDiagonal();
  b.covariance = Eigen::Matrix3d::Identity();
  const auto out = master.fuse(1, MotionInput(), {a, b});
  ASSERT_NEAR(out.weights[0], 0.5, 1e-9);
  EXPECT_NEAR(out.mean.x(), 1.0, 1e-6);   // prior 0 (information 1) + measurement 2 (1)
  EXPECT_NEAR(out.mean.y(), 0.25, 1e-6);  // 0.5 x its 0.5 m move
  EXPECT_NEAR(out.mean.z(), 0.0, 1e-6);
  EXPECT_NEAR(out.covariance(0, 0), 0.5, 1e-6);
  EXPECT_NEAR(out.covariance(1, 1), 1.0, 1e-6);  // no information gained along y
}

TEST(DpfMaster, ALocalWhosePriorDisagreesWithTheMastersIsNotFusedThenIsolated) {
  // Three locals predicted from the master's estimate (the origin) with the same odometry
  // (none): their priors must be the master's. Local 2's process is faulty: its prior is 3 m
  // off although its innovations (NIS 2) and Neff look healthy.
  DpfOptions o;
  o.local_filters = 3;
  o.isolate_after_steps = 2;
  auto local = [](int index, long step, const Pose2& prior, const Pose2& posterior) {
    DpfLocalEstimate e = estimateOf(index, step, posterior, 2.0, 0.9);
    e.prior_mean = prior;
    e.prior_covariance = 0.01 * Eigen::Matrix3d::Identity();
    e.covariance = 0.005 * Eigen::Matrix3d::Identity();
    return e;
  };
  const Pose2 off(3.0, 0.0, 0.0);
  DpfMaster master(o);
  auto out = master.fuse(1, MotionInput(), {local(0, 1, Pose2::Zero(), Pose2(0.1, 0.0, 0.0)),
                                            local(1, 1, Pose2::Zero(), Pose2(0.1, 0.0, 0.0)),
                                            local(2, 1, off, off + Pose2(0.1, 0.0, 0.0))});
  EXPECT_TRUE(master.health()[2].inconsistent);
  EXPECT_GT(master.health()[2].prior_nis, 100.0);
  EXPECT_FALSE(master.health()[0].inconsistent);
  EXPECT_EQ(out.weights[2], 0.0);
  // Locals 0 and 1 each measured x = 0.2 with the prior's information (posterior 0.1, half the
  // variance): fused with the prior, x = 2 * 0.2 / 3. Local 2's 3 m do not enter.
  EXPECT_NEAR(out.mean.x(), 0.4 / 3.0, 1e-6);
  EXPECT_TRUE(out.feedback.reinitialise.empty());
  // Without the check its information pulls the master towards it.
  DpfOptions blind_options = o;
  blind_options.fault_prior_chi2 = 0.0;
  DpfMaster blind(blind_options);
  const auto blind_out =
      blind.fuse(1, MotionInput(), {local(0, 1, Pose2::Zero(), Pose2(0.1, 0.0, 0.0)),
                                    local(1, 1, Pose2::Zero(), Pose2(0.1, 0.0, 0.0)),
                                    local(2, 1, off, off + Pose2(0.1, 0.0, 0.0))});
  EXPECT_GT(blind_out.weights[2], 0.1);
  // Second inconsistent step in a row: isolated (re-initialised from the master).
  const Pose2 m = out.mean;
  out = master.fuse(2, MotionInput(), {local(0, 2, m, m), local(1, 2, m, m),
                                       local(2, 2, m + off, m + off)});
  ASSERT_EQ(out.feedback.reinitialise.size(), 1u);
  EXPECT_EQ(out.feedback.reinitialise[0], 2);
  EXPECT_EQ(master.health()[2].isolations, 1);
  // When every local disagrees with the master's prediction, nothing is fused: the master
  // keeps its prediction instead of letting the inconsistent locals back in.
  const Pose2 p = out.mean;
  out = master.fuse(3, MotionInput(), {local(0, 3, p + off, p + off), local(1, 3, p - off, p - off),
                                       local(2, 3, p + off, p + off)});
  EXPECT_TRUE(out.mean.isApprox(p, 1e-9)) << out.mean.transpose();
}

// One estimate with a NaN (mean, or NIS) is not fused, counted, and isolated like an
// inconsistent one; the master stays finite and fuses the others. Before, the NaN mean entered
// the fusion with weight 0 (0 x NaN = NaN), the master's next prediction was NaN and every
// later local looked inconsistent: the filter stayed NaN for good; a NaN NIS stuck in the
// local's smoothed NIS for ever.
/// A healthy answer: prior at `at` (the master's prediction), posterior 0.1 m ahead in x.
DpfLocalEstimate movedEstimate(int index, long step, const Pose2& at) {
  DpfLocalEstimate e = estimateOf(index, step, at + Pose2(0.1, 0.0, 0.0), 2.0, 0.9);
  e.prior_mean = at;
  e.prior_covariance = 0.01 * Eigen::Matrix3d::Identity();
  e.covariance = 0.005 * Eigen::Matrix3d::Identity();
  return e;
}

DpfOptions threeLocalsIsolatedAfterTwo(const std::string& fusion) {
  DpfOptions o;
  o.local_filters = 3;
  o.isolate_after_steps = 2;
  o.fusion = fusion;
  return o;
}

TEST(DpfMaster, ANonFiniteEstimateIsNotFusedAndTheMasterStaysFinite) {
  for (const std::string fusion : {"information", "average"}) {
    DpfMaster master(threeLocalsIsolatedAfterTwo(fusion));
    const auto local = movedEstimate;
    DpfLocalEstimate bad = local(2, 1, Pose2::Zero());
    bad.mean.x() = std::numeric_limits<double>::quiet_NaN();
    auto out = master.fuse(1, MotionInput(), {local(0, 1, Pose2::Zero()), local(1, 1, Pose2::Zero()), bad});
    ASSERT_TRUE(out.mean.allFinite()) << fusion;
    EXPECT_TRUE(out.covariance.allFinite()) << fusion;
    EXPECT_EQ(out.weights[2], 0.0);
    EXPECT_TRUE(master.health()[2].inconsistent);
    EXPECT_EQ(master.health()[2].non_finite, 1);
    EXPECT_GT(out.mean.x(), 0.01) << fusion << ": the healthy locals were not fused";
    // A NaN NIS the next step: the second flagged step isolates it; its smoothed NIS stays finite.
    DpfLocalEstimate bad_nis = local(2, 2, out.mean);
    bad_nis.nis_sum = std::numeric_limits<double>::quiet_NaN();
    bad_nis.prior_mean.y() = std::numeric_limits<double>::quiet_NaN();  // no process fault
    const Pose2 m = out.mean;
    out = master.fuse(2, MotionInput(), {local(0, 2, m), local(1, 2, m), bad_nis});
    ASSERT_TRUE(out.mean.allFinite()) << fusion;
    EXPECT_EQ(master.health()[2].non_finite, 2);
    EXPECT_TRUE(std::isfinite(master.health()[2].smoothed_nis));
    ASSERT_EQ(out.feedback.reinitialise.size(), 1u);
    EXPECT_EQ(out.feedback.reinitialise[0], 2);
    // Clean again: fused again at once (a NaN prior counted as a process fault put it on
    // probation for readmit_after_steps).
    const Pose2 m2 = out.mean;
    out = master.fuse(3, MotionInput(), {local(0, 3, m2), local(1, 3, m2), local(2, 3, m2)});
    EXPECT_TRUE(out.mean.allFinite());
    EXPECT_GT(out.weights[2], 0.1) << fusion;
  }
}

TEST(DpfMaster, AMissedAnswerIsNotFusedCountedAndTheLocalIsFusedAgainWhenItAnswers) {
  for (const std::string fusion : {"information", "average"}) {
    DpfMaster master(threeLocalsIsolatedAfterTwo(fusion));
    const auto local = movedEstimate;
    auto out =
        master.fuse(1, MotionInput(),
                    {local(0, 1, Pose2::Zero()), local(1, 1, Pose2::Zero()), missedEstimate(2, 1)});
    ASSERT_TRUE(out.mean.allFinite() && out.covariance.allFinite()) << fusion;
    EXPECT_EQ(out.weights[2], 0.0) << fusion;
    EXPECT_EQ(master.health()[2].missed, 1);
    EXPECT_EQ(master.health()[2].non_finite, 0);
    EXPECT_GT(out.mean.x(), 0.01) << fusion << ": the answers were not fused";
    // No answer at all: the master keeps its prediction (a zero step: its last estimate).
    const Pose2 before = out.mean;
    const Eigen::Matrix3d before_covariance = out.covariance;
    out = master.fuse(2, MotionInput(),
                      {missedEstimate(0, 2), missedEstimate(1, 2), missedEstimate(2, 2)});
    ASSERT_TRUE(out.mean.allFinite() && out.covariance.allFinite()) << fusion;
    EXPECT_LT((out.mean - before).norm(), 1e-12) << fusion;
    EXPECT_LT((out.covariance - before_covariance).cwiseAbs().maxCoeff(), 1e-6) << fusion;
    EXPECT_EQ(master.health()[2].missed, 2);
    // Silence is no fault: two missed steps (isolate_after_steps) isolate nothing.
    EXPECT_EQ(master.health()[2].isolations, 0);
    EXPECT_TRUE(out.feedback.reinitialise.empty());
    // Back, redrawn from the master's estimate: fused again at once (no probation).
    const Pose2 m = out.mean;
    out = master.fuse(3, MotionInput(), {local(0, 3, m), local(1, 3, m), local(2, 3, m)});
    EXPECT_GT(out.weights[2], 0.1) << fusion;
  }
}

/// A healthy-looking answer (NIS 2, Neff 0.9) whose posterior is its prior.
DpfLocalEstimate atItsPrior(int index, long step, const Pose2& prior) {
  DpfLocalEstimate e = estimateOf(index, step, prior, 2.0, 0.9);
  e.prior_mean = prior;
  e.prior_covariance = 0.01 * Eigen::Matrix3d::Identity();
  e.covariance = 0.005 * Eigen::Matrix3d::Identity();
  return e;
}

// A local that does not answer a step is not judged: last step's verdict (inconsistent) does
// not stay on it while it is silent.
TEST(DpfMaster, ASilentLocalIsNotLeftInconsistent) {
  DpfOptions o;
  o.local_filters = 3;
  o.isolate_after_steps = 5;
  DpfMaster master(o);
  const auto local = atItsPrior;
  const Pose2 off(3.0, 0.0, 0.0);
  auto out = master.fuse(
      1, MotionInput(), {local(0, 1, Pose2::Zero()), local(1, 1, Pose2::Zero()), local(2, 1, off)});
  ASSERT_TRUE(master.health()[2].inconsistent);
  EXPECT_TRUE(master.health()[2].answered);
  const Pose2 m = out.mean;
  master.fuse(2, MotionInput(), {local(0, 2, m), local(1, 2, m), missedEstimate(2, 2)});
  EXPECT_FALSE(master.health()[2].inconsistent);
  EXPECT_FALSE(master.health()[2].answered);
}

TEST(DpfMaster, SegmentMahalanobisIsTheDistanceToTheNearestPointOfTheSegment) {
  const Eigen::Matrix3d unit = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d v(4.0, 0.0, 0.0);
  EXPECT_NEAR(segmentMahalanobis(Eigen::Vector3d(2.0, 0.0, 0.0), v, unit), 0.0, 1e-12);
  EXPECT_NEAR(segmentMahalanobis(Eigen::Vector3d(5.0, 0.0, 0.0), v, unit), 1.0, 1e-12);
  EXPECT_NEAR(segmentMahalanobis(Eigen::Vector3d(-1.0, 0.0, 0.0), v, unit), 1.0, 1e-12);
  EXPECT_NEAR(segmentMahalanobis(Eigen::Vector3d(2.0, 1.0, 0.0), v, unit), 1.0, 1e-12);
  EXPECT_NEAR(segmentMahalanobis(Eigen::Vector3d(2.0, 1.0, 0.0), v, 4.0 * unit), 0.25, 1e-12);
  EXPECT_NEAR(segmentMahalanobis(Eigen::Vector3d(0.0, 3.0, 0.0), Eigen::Vector3d::Zero(), unit),
              9.0, 1e-12);
}

/// Weight of local 2 at each step of a run where local 2's prior is 3 m off (alternating
/// sides: off the master's prediction and off its own last posterior) at the `faulty` steps,
/// and everything is healthy otherwise.
std::vector<double> weightsOfAFaultyLocal(int readmit_after_steps, const std::vector<int>& faulty,
                                          int steps) {
  DpfOptions o;
  o.local_filters = 3;
  o.isolate_after_steps = 2;
  o.readmit_after_steps = readmit_after_steps;
  DpfMaster master(o);
  const auto local = atItsPrior;
  std::vector<double> weights;
  Pose2 m = Pose2::Zero();
  for (int k = 1; k <= steps; ++k) {
    const bool fault = std::find(faulty.begin(), faulty.end(), k) != faulty.end();
    const Pose2 off(k % 2 ? 3.0 : -3.0, 0.0, 0.0);
    const auto out = master.fuse(k, MotionInput(), {local(0, k, m), local(1, k, m),
                                                    local(2, k, fault ? m + off : m)});
    weights.push_back(out.weights[2]);
    m = out.mean;
  }
  return weights;
}

TEST(DpfMaster, ALocalIsolatedForAProcessFaultIsFusedAgainOnlyAfterReadmitAfterStepsCleanSteps) {
  // Faulty at steps 1-2: isolated at step 2; healthy from step 3 on. Readmitted after 3
  // unflagged steps (3, 4, 5): fused from step 6.
  auto w = weightsOfAFaultyLocal(3, {1, 2}, 7);
  for (int k = 1; k <= 5; ++k) EXPECT_EQ(w[k - 1], 0.0) << "step " << k;
  EXPECT_GT(w[5], 0.2);
  EXPECT_GT(w[6], 0.2);
  // A flagged step during the probation (step 4) restarts the count: fused from step 8.
  w = weightsOfAFaultyLocal(3, {1, 2, 4}, 8);
  for (int k = 1; k <= 7; ++k) EXPECT_EQ(w[k - 1], 0.0) << "step " << k;
  EXPECT_GT(w[7], 0.2);
  // readmit_after_steps = 0 (the behaviour before): fused on its first unflagged step.
  w = weightsOfAFaultyLocal(0, {1, 2}, 3);
  EXPECT_GT(w[2], 0.2);
}

TEST(DpfMaster, APriorOnItsOwnLastPosteriorMovedByTheOdometryIsNoProcessFault) {
  // Local 2 keeps a correction of its own that the master did not take (its NIS flags it,
  // e.g. at a loop closure): its next prior is its posterior moved by the odometry, off the
  // master's prediction but no process fault; isolated for it, it is not kept out afterwards.
  // Local 1's prior is off both: a process fault.
  DpfOptions o;
  o.local_filters = 3;
  o.isolate_after_steps = 2;
  o.readmit_after_steps = 5;
  DpfMaster master(o);
  auto local = [](int index, long step, const Pose2& prior, const Pose2& posterior, double nis) {
    DpfLocalEstimate e = estimateOf(index, step, posterior, nis, 0.9);
    e.prior_mean = prior;
    e.prior_covariance = 0.01 * Eigen::Matrix3d::Identity();
    e.covariance = 0.005 * Eigen::Matrix3d::Identity();
    return e;
  };
  const Pose2 zero = Pose2::Zero();
  auto out = master.fuse(1, MotionInput(), {local(0, 1, zero, zero, 2.0),
                                            local(1, 1, zero, zero, 2.0),
                                            local(2, 1, zero, Pose2(2.0, 0.0, 0.0), 60.0)});
  EXPECT_TRUE(master.health()[2].suspect);  // its NIS
  MotionInput motion;
  motion.delta = Pose2(1.0, 0.0, 0.0);
  const Pose2 predicted = compose(out.mean, motion.delta);
  out = master.fuse(2, motion, {local(0, 2, predicted, predicted, 2.0),
                                local(1, 2, predicted + Pose2(0.0, 2.0, 0.0),
                                      predicted + Pose2(0.0, 2.0, 0.0), 2.0),
                                local(2, 2, Pose2(3.0, 0.0, 0.0), Pose2(3.0, 0.0, 0.0), 60.0)});
  EXPECT_TRUE(master.health()[2].inconsistent);  // off the master's prediction ...
  EXPECT_LT(master.health()[2].process_nis, 1.0);  // ... but on its own process
  EXPECT_TRUE(master.health()[1].inconsistent);
  EXPECT_GT(master.health()[1].process_nis, o.fault_prior_chi2);
  ASSERT_EQ(out.feedback.reinitialise.size(), 1u);  // local 2: flagged twice
  EXPECT_EQ(out.feedback.reinitialise[0], 2);
  EXPECT_EQ(master.health()[2].probation_steps, 0);
  // Step 3, everyone healthy: local 2 is fused at once.
  const Pose2 m = out.mean;
  out = master.fuse(3, MotionInput(), {local(0, 3, m, m, 2.0), local(1, 3, m, m, 2.0),
                                       local(2, 3, m, m, 2.0)});
  EXPECT_GT(out.weights[2], 0.2);
}

/// A synthetic run: a robot driving a circle of radius 10 m among 24 posts with known ids,
/// noisy odometry, range-bearing observations within 8 m.
struct SyntheticRun {
  std::vector<Pose2> truth;
  std::vector<MotionInput> motion;
  std::vector<FeatureSet> features;
};

SyntheticRun makeRun(int steps, unsigned seed) {
  Rng rng(seed);
  std::vector<Eigen::Vector2d> posts;
  for (int k = 0; k < 24; ++k) {
    const double a = 2.0 * M_PI * k / 24.0;
    const double r = k % 2 ? 6.5 : 13.5;
    posts.emplace_back(r * std::cos(a), 10.0 + r * std::sin(a));
  }
  SyntheticRun run;
  Pose2 pose(0.0, 0.0, 0.0);
  const Pose2 step_delta(0.5, 0.0, 0.05);
  for (int t = 0; t < steps; ++t) {
    pose = compose(pose, step_delta);
    run.truth.push_back(pose);
    MotionInput m;
    m.dt = 0.5;
    m.stamp = 0.5 * (t + 1);
    m.delta = step_delta + Pose2(sampleGaussian(rng, 0.05), sampleGaussian(rng, 0.02),
                                 sampleGaussian(rng, 0.02));
    run.motion.push_back(m);
    FeatureSet f;
    f.stamp = m.stamp;
    for (int k = 0; k < 24; ++k) {
      const Eigen::Vector2d d = transformPoint(inverse(pose), posts[k]);
      const double range = d.norm();
      if (range > 12.0) continue;
      PointFeature p;
      p.id = k;
      p.range = range + sampleGaussian(rng, 0.05);
      p.bearing = std::atan2(d.y(), d.x()) + sampleGaussian(rng, 0.01);
      p.covariance = Eigen::Vector2d(0.05 * 0.05, 0.01 * 0.01).asDiagonal();
      f.points.push_back(p);
    }
    run.features.push_back(f);
  }
  return run;
}

FilterOptions dpfOptions() {
  FilterOptions o;
  o.variant = "dpf";
  o.dpf.feedback_mode = "reweight";  // the default and config/landmarks_dpf.yaml's
  o.particles = 30;
  o.use_lines = false;
  o.motion.alpha1 = 0.05;
  o.motion.alpha2 = 0.01;
  o.motion.alpha3 = 0.02;
  o.motion.alpha4 = 0.01;
  o.motion.min_sigma_xy_m = 0.05;
  o.motion.min_sigma_theta_rad = 0.02;
  o.measurement.sigma_range_m = 0.05;
  o.measurement.sigma_bearing_rad = 0.01;
  o.measurement.use_feature_covariance = false;
  return o;
}

std::vector<Pose2> runFilter(SlamFilter* filter, const SyntheticRun& run) {
  std::vector<Pose2> out;
  for (size_t t = 0; t < run.motion.size(); ++t) {
    filter->predict(run.motion[t]);
    filter->update(run.features[t]);
    out.push_back(filter->estimate().mean);
  }
  return out;
}

double rmsError(const std::vector<Pose2>& a, const std::vector<Pose2>& b, size_t from = 0) {
  double sum = 0.0;
  for (size_t t = from; t < a.size(); ++t) sum += (a[t].head<2>() - b[t].head<2>()).squaredNorm();
  return std::sqrt(sum / (a.size() - from));
}

TEST(DistributedFilter, SameTrajectoryWhateverTheNumberOfThreads) {
  const SyntheticRun run = makeRun(80, 7);
  std::vector<std::vector<Pose2>> results;
  for (int threads : {1, 2, 3}) {
    FilterOptions o = dpfOptions();
    o.dpf.threads = threads;
    auto filter = createFilter(o);
    results.push_back(runFilter(filter.get(), run));
  }
  for (size_t k = 1; k < results.size(); ++k) {
    for (size_t t = 0; t < results[0].size(); ++t) {
      ASSERT_EQ(results[0][t], results[k][t]) << "threads differ at step " << t;
    }
  }
  FilterOptions other = dpfOptions();
  other.seed = 43;
  auto filter = createFilter(other);
  EXPECT_NE(runFilter(filter.get(), run).back(), results[0].back()) << "the seed must matter";
}

// A start pose with a spread (an initialpose before the first frame) draws every local
// filter's particles from it; after the first step it declines (the feedback and maps carry
// the old pose), so the node warns instead of reporting a pose it did not set.
TEST(DistributedFilter, TakesAStartPoseWithItsSpreadOnlyBeforeTheFirstStep) {
  const SyntheticRun run = makeRun(5, 7);
  auto filter = createFilter(dpfOptions());
  const Eigen::Matrix3d spread = Eigen::Vector3d(0.04, 0.04, 0.01).asDiagonal();
  ASSERT_TRUE(filter->resetPose(Pose2(1.0, -2.0, 0.5), spread));
  EXPECT_LT((filter->estimate().mean - Pose2(1.0, -2.0, 0.5)).norm(), 1e-9);
  double sxx = 0.0, mean_x = 0.0;
  const auto particles = filter->particles();
  for (const auto& p : particles) mean_x += p.pose.x() / particles.size();
  for (const auto& p : particles) sxx += std::pow(p.pose.x() - mean_x, 2) / particles.size();
  EXPECT_NEAR(mean_x, 1.0, 0.06);
  EXPECT_GT(sxx, 0.02) << "the particles must spread by the covariance";
  EXPECT_LT(sxx, 0.07);
  EXPECT_FALSE(filter->resetPose(Pose2(1.0, -2.0, 0.5), -spread));
  filter->predict(run.motion[0]);
  filter->update(run.features[0]);
  const Pose2 after = filter->estimate().mean;
  EXPECT_FALSE(filter->resetPose(Pose2(5.0, 5.0, 0.0), spread));
  EXPECT_EQ(filter->estimate().mean, after);
  filter->reset(Pose2::Zero());
  EXPECT_TRUE(filter->resetPose(Pose2(5.0, 5.0, 0.0), spread));  // a new run
}

// A sighting whose range is finite but absurd (1e160 m: a float64 field of a broken driver)
// overflowed its landmark's covariance in a local filter; the NaN spread to the master and,
// through the feedback, to every local for the rest of the run. One at 3.4e38 m (a float32's
// maximum) stayed finite, was mapped, and pulled the fused pose to 1e35 m. Now ranges beyond
// 1 km are refused like other unusable features and the filter keeps tracking.
TEST(DistributedFilter, AnAbsurdRangeDoesNotTurnTheFilterNaN) {
  for (double range : {1e160, 1e155, 3.4e38, 1e9}) {
  SyntheticRun run = makeRun(80, 11);
  for (int t : {10, 11, 30}) {
    PointFeature absurd;
    absurd.id = 99;
    absurd.range = range;
    absurd.bearing = 0.3;
    absurd.covariance = Eigen::Vector2d(0.05 * 0.05, 0.01 * 0.01).asDiagonal();
    run.features[t].points.push_back(absurd);
  }
  auto dpf = createFilter(dpfOptions());
  const std::vector<Pose2> path = runFilter(dpf.get(), run);
  for (size_t t = 0; t < path.size(); ++t) {
    ASSERT_TRUE(path[t].allFinite()) << "step " << t << ", range " << range;
  }
  EXPECT_TRUE(dpf->estimate().covariance.allFinite());
  std::vector<Pose2> odometry;
  Pose2 pose = Pose2::Zero();
  for (const auto& m : run.motion) odometry.push_back(pose = compose(pose, m.delta));
  EXPECT_LT(rmsError(path, run.truth), rmsError(odometry, run.truth)) << "range " << range;
  }
}

TEST(DistributedFilter, TracksAsWellAsFastSlam2AndBeatsOdometry) {
  const SyntheticRun run = makeRun(120, 11);
  FilterOptions o = dpfOptions();
  auto dpf = createFilter(o);
  const double dpf_error = rmsError(runFilter(dpf.get(), run), run.truth);
  o.variant = "fastslam2";
  auto fastslam = createFilter(o);
  const double fastslam_error = rmsError(runFilter(fastslam.get(), run), run.truth);
  std::vector<Pose2> odometry;
  Pose2 pose = Pose2::Zero();
  for (const auto& m : run.motion) odometry.push_back(pose = compose(pose, m.delta));
  const double odometry_error = rmsError(odometry, run.truth);
  EXPECT_LT(dpf_error, 0.5 * odometry_error) << dpf_error << " vs odometry " << odometry_error;
  EXPECT_LT(dpf_error, 1.5 * fastslam_error + 0.05) << dpf_error << " vs " << fastslam_error;
  EXPECT_EQ(dpf->landmarks().size(), fastslam->landmarks().size());
}

TEST(DistributedFilter, IsolatesAndReinitialisesTheFaultyLocalFilter) {
  const SyntheticRun run = makeRun(120, 5);
  FilterOptions o = dpfOptions();
  auto clean = std::make_unique<DistributedFilter>(o);
  const double clean_error = rmsError(runFilter(clean.get(), run), run.truth, 40);
  o.dpf.fault.enabled = true;
  o.dpf.fault.start_step = 40;
  o.dpf.fault.local_index = 1;
  o.dpf.fault.sigma_xy_m = 1.0;
  o.dpf.fault.sigma_theta_rad = 0.2;
  DistributedFilter faulty(o);
  const double faulty_error = rmsError(runFilter(&faulty, run), run.truth, 40);
  const auto& health = faulty.master().health();
  EXPECT_GT(health[1].isolations, 0);
  EXPECT_GT(faulty.local(1).reinitialisations(), 0);
  // Each isolation re-initialises the local with the next step's feedback (one may be pending).
  EXPECT_LE(faulty.local(1).reinitialisations(), health[1].isolations);
  EXPECT_GE(faulty.local(1).reinitialisations(), health[1].isolations - 1);
  EXPECT_GT(health[1].isolations, health[0].isolations + health[2].isolations);
  EXPECT_LT(faulty_error, 1.5 * clean_error + 0.05) << faulty_error << " vs " << clean_error;
  // Without isolation (never flagged) the same fault hurts more.
  o.dpf.fault_nis = 1e9;
  o.dpf.fault_neff_ratio = 0.0;
  o.dpf.fault_prior_chi2 = 0.0;
  o.dpf.weighting = "neff";
  DistributedFilter blind(o);
  const double blind_error = rmsError(runFilter(&blind, run), run.truth, 40);
  EXPECT_EQ(blind.master().health()[1].isolations, 0);
  EXPECT_GT(blind_error, faulty_error) << blind_error << " vs " << faulty_error;
}

// The per-local state /diagnostics shows (FilterStats::details), for dpf_master_node's operator.
TEST(DpfCoordinator, DetailsGiveEachLocalsStateAndCounts) {
  const SyntheticRun run = makeRun(3, 5);
  const FilterOptions o = dpfOptions();
  DpfCoordinator coordinator(o);
  std::vector<std::unique_ptr<DpfLocalStream>> streams;
  for (int i = 0; i < o.dpf.local_filters; ++i) {
    streams.push_back(std::make_unique<DpfLocalStream>(o, i));
  }
  auto details = coordinator.stats().details;
  ASSERT_EQ(details.size(), 3u);
  EXPECT_EQ(details[1].first, "local filter 1");
  EXPECT_EQ(details[1].second.rfind("no step yet", 0), 0u) << details[1].second;
  for (size_t t = 0; t < 2; ++t) {
    coordinator.predict(run.motion[t]);
    std::vector<Pose2> injected;
    const DpfStepInput input = coordinator.beginStep(run.features[t], &injected);
    std::vector<DpfLocalEstimate> estimates;
    for (int i = 0; i < 3; ++i) {
      if (t == 1 && i == 1) {  // local 1 misses step 2
        estimates.push_back(missedEstimate(i, input.step));
        continue;
      }
      DpfLocalEstimate e;
      streams[i]->step(input, Pose2::Zero(), injected[i], &e);
      estimates.push_back(e);
    }
    coordinator.finishStep(input, estimates);
  }
  details = coordinator.stats().details;
  ASSERT_EQ(details.size(), 3u);
  EXPECT_EQ(details[0].second.rfind("fused, weight ", 0), 0u) << details[0].second;
  EXPECT_EQ(details[1].second.rfind("missed the last step", 0), 0u) << details[1].second;
  EXPECT_NE(details[1].second.find("isolations 0, missed 1, non-finite 0"), std::string::npos)
      << details[1].second;
  EXPECT_NE(details[2].second.find("missed 0"), std::string::npos) << details[2].second;
}

// What dpf_master_node and dpf_local_node do when a local process dies, restarts in the middle
// of the run, or loses a step: the master fuses the steps without it (missedEstimate), the
// local resynchronises from the master's estimate that comes with the next step it sees.
TEST(DpfLocalStream, ALocalThatMissesStepsOrRestartsResynchronisesAndIsFusedAgain) {
  const SyntheticRun run = makeRun(120, 5);
  for (const bool feedback : {true, false}) {
    SCOPED_TRACE(feedback ? "feedback on" : "feedback off");
    FilterOptions o = dpfOptions();
    // Without feedback only the redraw brings a restarted local to the master's pose (with it,
    // the next feedback would move its cloud there too).
    o.dpf.feedback = feedback;
    const int n = o.dpf.local_filters;
    ASSERT_EQ(n, 3);
    auto runStreams = [&](bool with_losses, DpfCoordinator* coordinator,
                          std::vector<std::unique_ptr<DpfLocalStream>>* streams,
                          std::vector<DpfLocalStream::Outcome>* outcomes) {
      std::vector<Pose2> path;
      for (int i = 0; i < n; ++i) streams->push_back(std::make_unique<DpfLocalStream>(o, i));
      for (size_t t = 0; t < run.motion.size(); ++t) {
        coordinator->predict(run.motion[t]);
        std::vector<Pose2> injected;
        const DpfStepInput input = coordinator->beginStep(run.features[t], &injected);
        const long k = input.step;
        // Local 2 dies after step 30 and a new process takes over from step 41; local 0 loses
        // step 60's message.
        if (with_losses && k == 41) (*streams)[2] = std::make_unique<DpfLocalStream>(o, 2);
        std::vector<DpfLocalEstimate> estimates;
        for (int i = 0; i < n; ++i) {
          const bool lost = with_losses && ((i == 2 && k > 30 && k < 41) || (i == 0 && k == 60));
          if (lost) {
            estimates.push_back(missedEstimate(i, k));
            continue;
          }
          DpfLocalEstimate e;
          const auto outcome = (*streams)[i]->step(input, Pose2::Zero(), injected[i], &e);
          if (with_losses && ((i == 2 && k == 41) || (i == 0 && k == 61)))
            outcomes->push_back(outcome);
          estimates.push_back(e);
        }
        coordinator->finishStep(input, estimates);
        path.push_back(coordinator->estimate().mean);
      }
      return path;
    };
    DpfCoordinator clean(o), lossy(o);
    std::vector<std::unique_ptr<DpfLocalStream>> clean_streams, lossy_streams;
    std::vector<DpfLocalStream::Outcome> outcomes;
    const double clean_error =
        rmsError(runStreams(false, &clean, &clean_streams, &outcomes), run.truth);
    const double lossy_error =
        rmsError(runStreams(true, &lossy, &lossy_streams, &outcomes), run.truth);
    EXPECT_EQ(clean.stats().missed_answers, 0);
    EXPECT_EQ(lossy.stats().missed_answers, 11);
    EXPECT_EQ(lossy.master().health()[2].missed, 10);
    ASSERT_EQ(outcomes.size(), 2u);
    EXPECT_EQ(outcomes[0], DpfLocalStream::Outcome::kResynchronised);
    EXPECT_EQ(outcomes[1], DpfLocalStream::Outcome::kResynchronised);
    // Both are fused again at the end, the restarted one with a map of its own block.
    EXPECT_GT(lossy.master().last().weights[2], 0.05);
    EXPECT_GT(lossy.master().last().weights[0], 0.05);
    EXPECT_FALSE(localLandmarks(lossy_streams[2]->filter()).empty());
    EXPECT_LT(lossy_error, 1.5 * clean_error + 0.05) << lossy_error << " vs " << clean_error;
  }
  const FilterOptions o = dpfOptions();
  // A step delivered again is ignored; a gap with no master estimate to start from too.
  DpfLocalStream stream(o, 1);
  DpfLocalEstimate e;
  DpfStepInput first;
  first.step = 1;
  first.motion = run.motion[0];
  first.features = run.features[0];
  EXPECT_EQ(stream.step(first, Pose2::Zero(), Pose2::Zero(), &e),
            DpfLocalStream::Outcome::kStepped);
  EXPECT_EQ(stream.expected(), 2);
  DpfStepInput second = first;
  second.step = 2;
  EXPECT_EQ(stream.step(second, Pose2::Zero(), Pose2::Zero(), &e),
            DpfLocalStream::Outcome::kStepped);
  second.step = 2;
  EXPECT_EQ(stream.step(second, Pose2::Zero(), Pose2::Zero(), &e),
            DpfLocalStream::Outcome::kRepeated);
  DpfStepInput orphan = first;
  orphan.step = 9;  // feedback.step 0: nothing to resynchronise from
  EXPECT_EQ(stream.step(orphan, Pose2::Zero(), Pose2::Zero(), &e),
            DpfLocalStream::Outcome::kNoFeedback);
  EXPECT_EQ(stream.expected(), 3);
  // The master reset (a new run) and this local missed its step 1: step 2 of the new run is no
  // repeat. It starts over (no map from the last run) from the master's estimate.
  ASSERT_FALSE(localLandmarks(stream.filter()).empty());
  DpfStepInput next_run = first;
  next_run.run = first.run + 1;
  next_run.step = 2;
  next_run.feedback.step = 1;
  next_run.feedback.mean = Pose2(4.0, -2.0, 0.5);
  next_run.feedback.covariance = 1e-4 * Eigen::Matrix3d::Identity();
  next_run.features = FeatureSet();
  next_run.motion = MotionInput();
  EXPECT_EQ(stream.step(next_run, Pose2::Zero(), Pose2::Zero(), &e),
            DpfLocalStream::Outcome::kResynchronised);
  EXPECT_TRUE(localLandmarks(stream.filter()).empty());
  EXPECT_LT((e.prior_mean.head<2>() - Pose2(4.0, -2.0, 0.5).head<2>()).norm(), 0.1);
  EXPECT_EQ(stream.expected(), 3);
}

TEST(FaultInjector, CentralisedFilterGetsTheSameDisturbance) {
  FaultInjectorOptions o;
  o.enabled = true;
  o.start_step = 3;
  FaultInjector a(o, 42), b(o, 42);
  EXPECT_EQ(a.disturbance(2), Pose2::Zero());
  const Pose2 d = a.disturbance(3);
  EXPECT_NE(d, Pose2::Zero());
  EXPECT_EQ(b.disturbance(3), d);
  FilterOptions f = dpfOptions();
  f.variant = "fastslam2";
  f.dpf.fault = o;
  EXPECT_EQ(createFilter(f)->variant(), "fastslam2");  // wrapped, same interface
  // ... all of it: the best path (the trajectory offline_slam writes) and, for grid_pf, the grid.
  const std::unique_ptr<SlamFilter> wrapped = createFilter(f);
  wrapped->reset(Pose2::Zero());
  MotionInput step;
  step.delta = Pose2(0.1, 0.0, 0.0);
  wrapped->predict(step);
  wrapped->update(FeatureSet());
  EXPECT_FALSE(wrapped->bestPath().empty());
  f.variant = "grid_pf";
  f.particles = 5;
  const std::unique_ptr<SlamFilter> grid = createFilter(f);
  grid->reset(Pose2::Zero());
  grid->predict(step);
  grid->update(FeatureSet());
  GridMapData data;
  EXPECT_TRUE(grid->occupancyGrid(data));
  // ... and what the variant reads: a wrapped grid_pf still leaves features alone.
  EXPECT_FALSE(grid->usesLandmarkFeatures());
  EXPECT_TRUE(wrapped->usesLandmarkFeatures());
}

TEST(DpfOptions, OutOfRangeValuesAreNamed) {
  FilterOptions o = dpfOptions();
  o.dpf.weighting = "votes";
  try {
    createFilter(o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("dpf.weighting"), std::string::npos);
  }
  o = dpfOptions();
  o.dpf.fault.local_index = 3;  // only 3 local filters: 0..2
  EXPECT_THROW(createFilter(o), std::invalid_argument);
  o = dpfOptions();
  o.dpf.readmit_after_steps = -1;
  EXPECT_THROW(createFilter(o), std::invalid_argument);
}

TEST(DpfConfig, TheShippedConfigAndItsErrors) {
  const io::SlamConfig c =
      io::loadSlamConfig(std::string(RBPF_SOURCE_DIR) + "/config/landmarks_dpf.yaml");
  EXPECT_EQ(c.filter.variant, "dpf");
  EXPECT_EQ(c.filter.dpf.local_filters, 3);
  EXPECT_EQ(c.filter.dpf.weighting, "mixed");
  EXPECT_EQ(c.filter.dpf.fusion, "information");
  EXPECT_TRUE(c.filter.dpf.adaptive_covariance);
  EXPECT_EQ(c.filter.dpf.feedback_mode, "reweight");
  EXPECT_EQ(c.filter.dpf.feedback_mode, DpfOptions().feedback_mode);  // code default = shipped
  EXPECT_DOUBLE_EQ(c.filter.dpf.fault_prior_chi2, DpfOptions().fault_prior_chi2);
  EXPECT_FALSE(c.filter.dpf.fault.enabled);
  EXPECT_EQ(c.filter.dpf.fault.start_step, 1000);
  EXPECT_EQ(createFilter(c.filter)->variant(), "dpf");
  auto errorOf = [](const std::string& yaml) -> std::string {
    try {
      io::parseSlamConfig(YAML::Load(yaml), "t.yaml");
    } catch (const io::ConfigError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(errorOf("variant: dpf\ndpf: {bogus: 1}").find("bogus"), std::string::npos);
  EXPECT_NE(errorOf("variant: dpf\ndpf: {weighting: votes}").find("weighting"), std::string::npos);
  EXPECT_NE(errorOf("variant: dpf\ndpf: {local_filters: 0}").find("local_filters"),
            std::string::npos);
  EXPECT_NE(errorOf("variant: dpf\nfault: {local_index: 5}").find("fault.local_index"),
            std::string::npos);
  EXPECT_EQ(errorOf("variant: fastslam2\nfault: {enabled: true, start_step: 5}"), "");
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam
