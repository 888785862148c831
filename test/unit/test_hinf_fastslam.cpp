// H-infinity FastSLAM (Havangi et al.): the H-infinity correction against
// hand-computed and information-form values, its limit (the EKF) and its
// fallback, the variant in the factory, and the filter on a small simulated
// landmark world with a fixed seed.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "rbpf_slam/core/filters/estimator_rule.h"
#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/hinf_fastslam.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/motion/motion_model.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {
namespace {

Eigen::Matrix3d randomCovariance(Rng& rng) {
  Eigen::Matrix3d a;
  for (int i = 0; i < 9; ++i) a(i / 3, i % 3) = sampleGaussian(rng, 1.0);
  return a * a.transpose() + 0.5 * Eigen::Matrix3d::Identity();
}

/// A measurement Jacobian with standard normal entries (row by row, as the tests drew it).
Eigen::Matrix<double, 2, 3> randomJacobian(Rng& rng) {
  Eigen::Matrix<double, 2, 3> h;
  for (int i = 0; i < 6; ++i) h(i / 3, i % 3) = sampleGaussian(rng, 1.0);
  return h;
}

TEST(HinfCorrection, DiagonalCaseMatchesHandComputation) {
  // P = diag(4, 1), H = I, R = diag(1, 0.25), gamma = 2:
  // P+ = diag(1 / (1/4 + 1 - 1/2), 1 / (1 + 4 - 1/2)) = diag(4/3, 2/9).
  const Eigen::Matrix2d p = Eigen::Vector2d(4.0, 1.0).asDiagonal();
  const Eigen::Matrix2d r = Eigen::Vector2d(1.0, 0.25).asDiagonal();
  const Correction<2> c =
      hinfCorrection<2>(p, Eigen::Matrix2d::Identity(), r, Eigen::Vector2d(2.0, 2.0), true);
  ASSERT_TRUE(c.ok);
  EXPECT_FALSE(c.fallback);
  EXPECT_NEAR(c.covariance(0, 0), 4.0 / 3.0, 1e-12);
  EXPECT_NEAR(c.covariance(1, 1), 2.0 / 9.0, 1e-12);
  EXPECT_NEAR(c.covariance(0, 1), 0.0, 1e-12);
  // Posterior gain P+ R^-1 = diag(4/3, 8/9); the EKF gain would be diag(4/5,
  // 4/5).
  EXPECT_NEAR(c.gain(0, 0), 4.0 / 3.0, 1e-12);
  EXPECT_NEAR(c.gain(1, 1), 8.0 / 9.0, 1e-12);
  // The prior (Kalman-form, eq. 20) gain is the EKF gain on the same prior.
  const Correction<2> prior =
      hinfCorrection<2>(p, Eigen::Matrix2d::Identity(), r, Eigen::Vector2d(2.0, 2.0), false);
  EXPECT_NEAR(prior.gain(0, 0), 0.8, 1e-12);
  EXPECT_NEAR(prior.gain(1, 1), 0.8, 1e-12);
  EXPECT_NEAR(prior.covariance(0, 0), 4.0 / 3.0, 1e-12);
}

/// Eqs. 22, 23 as printed: R_e = [R 0; 0 -Gamma] + [H; I] P [H^T I], P+ = P - P
/// [H^T I] R_e^-1 [H; I] P.
Eigen::Matrix3d paperCovariance(const Eigen::Matrix3d& p, const Eigen::Matrix<double, 2, 3>& h,
                                const Eigen::Matrix2d& r, const Eigen::Vector3d& gamma) {
  Eigen::Matrix<double, 5, 3> stacked;
  stacked << h, Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, 5, 5> r_e = stacked * p * stacked.transpose();
  r_e.topLeftCorner<2, 2>() += r;
  r_e.bottomRightCorner<3, 3>() -= Eigen::Matrix3d(gamma.asDiagonal());
  return p - p * stacked.transpose() * r_e.inverse() * stacked * p;
}

TEST(HinfCorrection, InflationGuardFallsBackNearTheBound) {
  // Same case: P_ekf = diag(4/5, 1/5), I - Gamma^-1 P_ekf = diag(0.6, 0.9): P+ is 1/0.6 = 1.67
  // times P_ekf along x. A guard of 2 lets it through, one of 1.5 does not.
  const Eigen::Matrix2d p = Eigen::Vector2d(4.0, 1.0).asDiagonal();
  const Eigen::Matrix2d r = Eigen::Vector2d(1.0, 0.25).asDiagonal();
  const Eigen::Vector2d gamma(2.0, 2.0);
  const Correction<2> loose =
      hinfCorrection<2>(p, Eigen::Matrix2d::Identity(), r, gamma, true, 2.0);
  EXPECT_FALSE(loose.fallback);
  EXPECT_NEAR(loose.covariance(0, 0), 4.0 / 3.0, 1e-12);
  const Correction<2> tight =
      hinfCorrection<2>(p, Eigen::Matrix2d::Identity(), r, gamma, true, 1.5);
  EXPECT_TRUE(tight.fallback);
  EXPECT_NEAR(tight.covariance(0, 0), 0.8, 1e-12);
  EXPECT_NEAR(tight.gain(0, 0), 0.8, 1e-12);
}

TEST(HinfCorrection, CovarianceMatchesInformationFormForPoseJacobians) {
  Rng rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Matrix3d p = randomCovariance(rng);
    const Eigen::Matrix<double, 2, 3> h = randomJacobian(rng);
    const Eigen::Matrix2d r = Eigen::Vector2d(0.3, 0.7).asDiagonal();
    const Eigen::Vector3d gamma(20.0, 20.0, 40.0);
    const Eigen::Matrix3d information = p.inverse() + h.transpose() * r.inverse() * h -
                                        Eigen::Matrix3d(gamma.cwiseInverse().asDiagonal());
    const Correction<3> c = hinfCorrection<3>(p, h, r, gamma, true);
    ASSERT_TRUE(c.ok);
    ASSERT_FALSE(c.fallback) << "min eigenvalue " << information.eigenvalues().real().minCoeff();
    EXPECT_LT((c.covariance - information.inverse()).norm(), 1e-9);
    EXPECT_LT((c.covariance - paperCovariance(p, h, r, gamma)).norm(), 1e-9);
    EXPECT_LT((c.gain - information.inverse() * h.transpose() * r.inverse()).norm(), 1e-9);
    // Attenuation keeps the covariance above the EKF's: P+ - P_ekf is positive
    // semidefinite.
    const Correction<3> ekf = ekfCorrection<3>(p, h, r);
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c.covariance - ekf.covariance)
                  .eigenvalues()
                  .minCoeff(),
              -1e-12);
  }
}

TEST(HinfCorrection, StepAttenuationIsOneUpdateWithEveryLandmarkStacked) {
  // Two landmarks' EKF updates in sequence, then one attenuation, equal the
  // H-infinity update of the stacked 4D measurement: P+^-1 = P^-1 + sum H_k^T
  // R_k^-1 H_k - Gamma^-1, and the mean moves by P+ sum H_k^T R_k^-1 v_k.
  Rng rng(12);
  const Eigen::Matrix3d p = randomCovariance(rng);
  Eigen::Matrix<double, 2, 3> h1, h2;
  h1 << -0.8, -0.6, 0.0, 0.12, -0.16, -1.0;
  h2 << 0.6, -0.8, 0.0, 0.16, 0.12, -1.0;
  const Eigen::Matrix2d r1 = Eigen::Vector2d(0.04, 0.001).asDiagonal();
  const Eigen::Matrix2d r2 = Eigen::Vector2d(0.09, 0.002).asDiagonal();
  const Eigen::Vector2d v1(0.1, -0.02), v2(-0.05, 0.01);
  const Correction<3> c1 = ekfCorrection<3>(p, h1, r1);
  Eigen::Vector3d shift = c1.gain * v1;
  const Correction<3> c2 = ekfCorrection<3>(c1.covariance, h2, r2);
  shift += c2.gain * (v2 - h2 * shift);
  const Eigen::Vector3d gamma(0.5, 0.5, 0.05);
  const Attenuation<3> a = hinfAttenuation<3>(c2.covariance, gamma, true);
  ASSERT_FALSE(a.fallback);
  const Eigen::Matrix3d information = p.inverse() + h1.transpose() * r1.inverse() * h1 +
                                      h2.transpose() * r2.inverse() * h2 -
                                      Eigen::Matrix3d(gamma.cwiseInverse().asDiagonal());
  EXPECT_LT((a.covariance - information.inverse()).norm(), 1e-9);
  const Eigen::Vector3d expected = information.inverse() * (h1.transpose() * r1.inverse() * v1 +
                                                            h2.transpose() * r2.inverse() * v2);
  EXPECT_LT((a.correction_scale * shift - expected).norm(), 1e-9);
  // The prior gain keeps the EKF's mean and only widens the covariance.
  const Attenuation<3> prior = hinfAttenuation<3>(c2.covariance, gamma, false);
  EXPECT_EQ(prior.correction_scale, Eigen::Matrix3d::Identity());
  EXPECT_LT((prior.covariance - a.covariance).norm(), 1e-12);
}

TEST(HinfCorrection, ReducesToTheEkfAsGammaGrows) {
  Rng rng(8);
  const Eigen::Matrix3d p = randomCovariance(rng);
  Eigen::Matrix<double, 2, 3> h;
  h << -0.8, -0.6, 0.0, 0.12, -0.16, -1.0;  // a point landmark 5 m away
  const Eigen::Matrix2d r = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  const Correction<3> ekf = ekfCorrection<3>(p, h, r);
  double previous_gap = INFINITY;
  for (double gamma : {1.0, 10.0, 100.0, 1e4, 1e8}) {
    const Correction<3> c = hinfCorrection<3>(p, h, r, Eigen::Vector3d::Constant(gamma), true);
    ASSERT_TRUE(c.ok);
    ASSERT_FALSE(c.fallback) << "gamma " << gamma;
    const double gap = (c.gain - ekf.gain).norm() + (c.covariance - ekf.covariance).norm();
    EXPECT_LT(gap, previous_gap) << "gamma " << gamma;
    previous_gap = gap;
  }
  EXPECT_LT(previous_gap, 1e-6);
  const Correction<3> exact = hinfCorrection<3>(p, h, r, Eigen::Vector3d::Constant(INFINITY), true);
  EXPECT_EQ(exact.gain, ekf.gain);
  EXPECT_EQ(exact.covariance, ekf.covariance);
}

TEST(HinfCorrection, FallsBackToTheEkfWhenTheConditionFails) {
  // Information of the posterior along x: 1/4 + 1 = 1.25 < 1/gamma = 2: no
  // H-infinity solution.
  const Eigen::Matrix2d p = Eigen::Vector2d(4.0, 0.1).asDiagonal();
  const Eigen::Matrix2d r = Eigen::Matrix2d::Identity();
  const Correction<2> c =
      hinfCorrection<2>(p, Eigen::Matrix2d::Identity(), r, Eigen::Vector2d(0.5, 0.5), true);
  const Correction<2> ekf = ekfCorrection<2>(p, Eigen::Matrix2d::Identity(), r);
  ASSERT_TRUE(c.ok);
  EXPECT_TRUE(c.fallback);
  EXPECT_EQ(c.gain, ekf.gain);
  EXPECT_EQ(c.covariance, ekf.covariance);
  EXPECT_TRUE(c.covariance.allFinite());
}

TEST(HinfRelative, IsTheEkfWithTheNoiseScaledByOneMinusTheta) {
  // Gamma^-1 = theta P^-1: P+ = ((1 - theta) P^-1 + H^T R^-1 H)^-1, and the posterior gain
  // P+ H^T R^-1 is the EKF gain of the same prior with R (1 - theta).
  Rng rng(17);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Matrix3d p = randomCovariance(rng);
    const Eigen::Matrix<double, 2, 3> h = randomJacobian(rng);
    const Eigen::Matrix2d r = Eigen::Vector2d(0.3, 0.7).asDiagonal();
    for (double theta : {0.0, 0.5, 0.9, 0.99}) {
      const Correction<3> ekf = ekfCorrection<3>(p, h, r);
      const Attenuation<3> a =
          hinfAttenuationInformation<3>(ekf.covariance, relativeGammaInverse<3>(p, theta), true);
      ASSERT_FALSE(a.fallback) << "theta " << theta;
      const Eigen::Matrix3d information =
          (1.0 - theta) * p.inverse() + h.transpose() * r.inverse() * h;
      EXPECT_LT((a.covariance - information.inverse()).norm(), 1e-8 * (1.0 + information.inverse().norm()));
      const Correction<3> scaled = ekfCorrection<3>(p, h, (1.0 - theta) * r);
      EXPECT_LT((a.correction_scale * ekf.gain - scaled.gain).norm(), 1e-8 * (1.0 + scaled.gain.norm()))
          << "theta " << theta;
      // The covariance never grows beyond 1 / (1 - theta) times the EKF's.
      const Eigen::Matrix3d slack = ekf.covariance / (1.0 - theta) - a.covariance;
      EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(slack).eigenvalues().minCoeff(),
                -1e-9);
    }
  }
}

TEST(HinfRelative, IsScaleFree) {
  // The same problem in other units (P and R times s): the absolute gamma that suits one scale
  // fails the condition at another, the relative rule scales P+ by s and keeps the gain.
  const Eigen::Matrix3d p = Eigen::Vector3d(0.04, 0.04, 0.01).asDiagonal();
  Eigen::Matrix<double, 2, 3> h;
  h << -0.8, -0.6, 0.0, 0.12, -0.16, -1.0;
  const Eigen::Matrix2d r = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  HinfOptions relative;
  relative.mode = "relative";
  relative.theta_pose = 0.9;
  relative.theta_landmark = 0.5;
  HinfOptions absolute = relative;
  absolute.mode = "absolute";
  absolute.gamma_position = 0.05;
  absolute.gamma_heading = 0.05;
  absolute.gamma_landmark = 0.05;
  const HinfRule rel(relative), abs(absolute);
  const Attenuation<3> base = rel.attenuatePose(p, ekfCorrection<3>(p, h, r).covariance);
  ASSERT_FALSE(base.fallback);
  const Eigen::Matrix2d pl = Eigen::Vector2d(0.02, 0.01).asDiagonal();
  const Correction<2> base_landmark = rel.correctLandmark(pl, h.leftCols<2>(), r);
  ASSERT_FALSE(base_landmark.fallback);
  bool absolute_failed_somewhere = false;
  for (double s : {1e-4, 1e-2, 1.0, 1e2, 1e4}) {
    const Eigen::Matrix3d ekf = ekfCorrection<3>(s * p, h, s * r).covariance;
    const Attenuation<3> a = rel.attenuatePose(s * p, ekf);
    EXPECT_FALSE(a.fallback) << "scale " << s;
    EXPECT_LT((a.covariance / s - base.covariance).norm(), 1e-9 * base.covariance.norm());
    EXPECT_LT((a.correction_scale - base.correction_scale).norm(), 1e-9);
    const Correction<2> l = rel.correctLandmark(s * pl, h.leftCols<2>(), s * r);
    EXPECT_FALSE(l.fallback) << "scale " << s;
    EXPECT_LT((l.gain - base_landmark.gain).norm(), 1e-9);
    absolute_failed_somewhere = absolute_failed_somewhere || abs.attenuatePose(s * p, ekf).fallback;
  }
  EXPECT_TRUE(absolute_failed_somewhere);
  // theta 0 is the EKF exactly.
  relative.theta_pose = 0.0;
  const Eigen::Matrix3d ekf = ekfCorrection<3>(p, h, r).covariance;
  const Attenuation<3> none = HinfRule(relative).attenuatePose(p, ekf);
  EXPECT_EQ(none.covariance, ekf);
  EXPECT_EQ(none.correction_scale, Eigen::Matrix3d::Identity());
}

// One observation of a relative-mode step (theta 0.9), shared by the proposal-draw tests.
struct ProposalStep {
  Eigen::Matrix3d p = Eigen::Vector3d(0.04, 0.04, 0.01).asDiagonal();
  Eigen::Matrix<double, 2, 3> h =
      (Eigen::Matrix<double, 2, 3>() << -0.8, -0.6, 0.0, 0.12, -0.16, -1.0).finished();
  Eigen::Matrix2d r = Eigen::Vector2d(0.01, 0.0004).asDiagonal();
  Eigen::Matrix3d ekf = ekfCorrection<3>(p, h, r).covariance;
  static HinfOptions options(const std::string& draw) {
    HinfOptions o;
    o.mode = "relative";
    o.theta_pose = 0.9;
    o.proposal_covariance = draw;
    return o;
  }
};

TEST(HinfRelative, EkfProposalCovarianceKeepsTheHinfMean) {
  const ProposalStep step;
  const Eigen::Matrix3d& p = step.p;
  const Eigen::Matrix3d& ekf = step.ekf;
  const Attenuation<3> paper = HinfRule(ProposalStep::options("hinf")).attenuatePose(p, ekf);
  const Attenuation<3> drawn = HinfRule(ProposalStep::options("ekf")).attenuatePose(p, ekf);
  EXPECT_EQ(drawn.covariance, ekf);
  EXPECT_EQ(drawn.correction_scale, paper.correction_scale);
  EXPECT_GT((paper.covariance - ekf).norm(), 1e-6);  // P+ is wider than the EKF's
  EXPECT_GT((drawn.correction_scale - Eigen::Matrix3d::Identity()).norm(), 1e-3);
}

// proposal_covariance scaled: the draw is the EKF posterior with R scaled by 1 - theta, the
// Gaussian whose mean the H-infinity step gives, i.e. (P^-1 + H^T ((1 - theta) R)^-1 H)^-1.
TEST(HinfRelative, ScaledProposalCovarianceIsTheEkfWithScaledNoise) {
  const ProposalStep step;
  const Eigen::Matrix3d& p = step.p;
  const Eigen::Matrix<double, 2, 3>& h = step.h;
  const Eigen::Matrix2d& r = step.r;
  const Eigen::Matrix3d& ekf = step.ekf;
  HinfOptions o = ProposalStep::options("scaled");
  const Attenuation<3> scaled = HinfRule(o).attenuatePose(p, ekf);
  const Eigen::Matrix3d expected =
      (p.inverse() + h.transpose() * (0.1 * r).inverse() * h).inverse();
  EXPECT_LT((scaled.covariance - expected).norm(), 1e-9 * expected.norm());
  const Attenuation<3> drawn = HinfRule(ProposalStep::options("ekf")).attenuatePose(p, ekf);
  EXPECT_EQ(scaled.correction_scale, drawn.correction_scale);  // the same mean
  EXPECT_LT(expected.trace(), ekf.trace());  // narrower than the EKF's with R as given

  // Three observations folded in one after the other (as FastSlam2::refineProposal does): the
  // same as the stacked EKF with every R scaled.
  Eigen::Matrix<double, 2, 3> h2, h3;
  h2 << 0.6, -0.8, 0.0, 0.16, 0.12, -1.0;
  h3 << -0.28, 0.96, 0.0, -0.19, -0.05, -1.0;
  const Eigen::Matrix2d r2 = Eigen::Vector2d(0.04, 0.001).asDiagonal();
  Eigen::Matrix3d sequential = ekf;
  for (const auto& [hk, rk] : {std::make_pair(h2, r2), std::make_pair(h3, r)}) {
    sequential = ekfCorrection<3>(sequential, hk, rk).covariance;
  }
  const Eigen::Matrix3d stacked =
      (p.inverse() + h.transpose() * (0.1 * r).inverse() * h +
       h2.transpose() * (0.1 * r2).inverse() * h2 + h3.transpose() * (0.1 * r).inverse() * h3)
          .inverse();
  const Attenuation<3> three = HinfRule(o).attenuatePose(p, sequential);
  EXPECT_LT((three.covariance - stacked).norm(), 1e-9 * stacked.norm());

  // No attenuated step (a prior that cannot be inverted): the draw is the EKF's, not shrunk.
  const Eigen::Matrix3d singular = Eigen::Vector3d(0.04, 0.04, 0.0).asDiagonal();
  const Attenuation<3> none = HinfRule(o).attenuatePose(singular, ekf);
  EXPECT_EQ(none.covariance, ekf);

  // Absolute gammas have no noise scale, the prior gain another mean: both refused by name.
  for (const auto& [mode, gain] : {std::make_pair("absolute", "posterior"),
                                   std::make_pair("relative", "prior")}) {
    o.mode = mode;
    o.gain = gain;
    try {
      validate(o);
      ADD_FAILURE() << "proposal_covariance scaled accepted with mode " << mode << ", gain "
                    << gain;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("hinf.proposal_covariance"), std::string::npos);
    }
  }
}

// Adaptive mode: theta = 1 - s with s the scale of R the innovations are consistent with. A
// stand-in filter whose innovations have variance true_scale x R gives NIS values with mean
// 2 true_scale / s at the scale s in use; the rule must settle at s = true_scale, within
// [1 - theta_pose, 1].
TEST(HinfAdaptive, ThetaSettlesWhereTheInnovationsAreConsistent) {
  HinfOptions o;
  o.mode = "adaptive";
  o.theta_pose = 0.99;
  o.adapt_steps = 20;
  auto step = [&](HinfRule* rule, double true_scale) {
    const double m = 2.0 * true_scale / (1.0 - rule->theta());
    rule->observeInnovations({0.2 * m, m, 1.8 * m, 0.5 * m, 1.5 * m});  // five matches, mean m
  };
  for (const auto& [true_scale, expected_theta] : std::vector<std::pair<double, double>>{
           {0.04, 0.96}, {0.25, 0.75}, {1.0, 0.0}, {3.0, 0.0}, {0.001, 0.99}}) {
    HinfRule rule(o);
    EXPECT_TRUE(rule.learnsFromInnovations());
    EXPECT_EQ(rule.theta(), 0.0) << "no innovation yet: the EKF";
    for (int k = 0; k < 400; ++k) step(&rule, true_scale);
    EXPECT_NEAR(rule.theta(), expected_theta, 0.01) << "R overstated " << 1.0 / true_scale << "x";
    EXPECT_NEAR(rule.weightNoiseScale(), 1.0, 1e-12) << "marginal weights: R as given";
    rule.observeInnovations({std::numeric_limits<double>::quiet_NaN()});  // ignored
    rule.observeInnovations({});                                          // ignored
    EXPECT_NEAR(rule.theta(), expected_theta, 0.01);
    rule.reset();
    EXPECT_EQ(rule.theta(), 0.0) << "reset forgets the learnt scale";
  }
  o.weight = "attenuated";
  HinfRule attenuated(o);
  for (int k = 0; k < 400; ++k) step(&attenuated, 0.25);
  EXPECT_NEAR(attenuated.weightNoiseScale(), 0.25, 0.01);
  o.mode = "relative";
  o.theta_pose = 0.8;
  HinfRule relative(o);
  EXPECT_FALSE(relative.learnsFromInnovations());
  relative.observeInnovations({0.01});
  EXPECT_DOUBLE_EQ(relative.theta(), 0.8) << "relative mode: theta as configured";
  o.mode = "absolute";
  try {  // no theta to attenuate the weight by: it would be the marginal one without a word
    HinfRule refused(o);
    ADD_FAILURE() << "weight attenuated accepted with mode absolute";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("hinf.weight 'attenuated'"), std::string::npos) << e.what();
  }
  o.weight = "marginal";
  EXPECT_EQ(HinfRule(o).theta(), 0.0);
}

TEST(MotionRandomWalk, GrowsWithTheStepDuration) {
  // A stationary step of dt seconds: only the floors and the random walk remain.
  MotionOptions o;
  o.alpha1 = o.alpha2 = o.alpha3 = o.alpha4 = 0.0;
  o.min_sigma_xy_m = 0.01;
  o.min_sigma_theta_rad = 0.02;
  o.sigma_xy_per_sqrt_s = 0.03;
  o.sigma_theta_per_sqrt_s = 0.05;
  for (const std::string model : {"odometry", "diff_drive"}) {
    o.model = model;
    const std::unique_ptr<MotionModel> m = createMotionModel(o);
    MotionInput motion;
    for (double dt : {0.0, 1.0, 40.0}) {
      motion.dt = dt;
      const Eigen::Matrix3d c = m->covariance(Pose2::Zero(), motion);
      EXPECT_NEAR(c(0, 0), 1e-4 + dt * 9e-4, 1e-12) << model << " dt " << dt;
      EXPECT_NEAR(c(2, 2), 4e-4 + dt * 25e-4, 1e-12) << model << " dt " << dt;
    }
    motion.dt = 40.0;
    Rng rng(5);
    double sq = 0.0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
      const double z = m->sample(Pose2::Zero(), motion, rng).z();
      sq += z * z;
    }
    EXPECT_NEAR(std::sqrt(sq / n), std::sqrt(4e-4 + 40.0 * 25e-4), 0.01) << model;
  }
  o.sigma_theta_per_sqrt_s = -1.0;
  EXPECT_THROW(createMotionModel(o), std::invalid_argument);
}

TEST(MotionNoiseScale, CovarianceDescribesTheScaledSamples) {
  // A scan-matched step (noise_scale < 1) or a gap (> 1) scales every part of the draw, the
  // floors included; the covariance the proposals use must scale alike, for both models.
  MotionOptions o;
  o.alpha1 = 0.05;
  o.alpha2 = 0.02;
  o.alpha3 = 0.05;
  o.alpha4 = 0.02;
  o.wheel_base_m = 0.4;
  o.wheel_alpha1 = 0.05;
  o.wheel_alpha2 = 0.02;
  o.min_sigma_xy_m = 0.02;
  o.min_sigma_theta_rad = 0.01;
  for (const std::string model : {"odometry", "diff_drive"}) {
    o.model = model;
    const std::unique_ptr<MotionModel> m = createMotionModel(o);
    MotionInput motion;
    motion.delta = Pose2(0.3, 0.02, 0.1);
    const Eigen::Matrix3d unscaled = m->covariance(Pose2::Zero(), motion);
    motion.noise_scale = 3.0;
    const Eigen::Matrix3d scaled = m->covariance(Pose2::Zero(), motion);
    EXPECT_LT((scaled - 9.0 * unscaled).norm(), 1e-9 * unscaled.norm()) << model;
    // The samples' spread matches the covariance given for them (x and heading).
    Rng rng(11);
    const Pose2 mean = m->mean(Pose2::Zero(), motion);
    double sq_x = 0.0, sq_z = 0.0;
    const int n = 40000;
    for (int i = 0; i < n; ++i) {
      const Pose2 d = m->sample(Pose2::Zero(), motion, rng) - mean;
      sq_x += d.x() * d.x();
      sq_z += wrapAngle(d.z()) * wrapAngle(d.z());
    }
    EXPECT_NEAR(sq_x / n / scaled(0, 0), 1.0, 0.05) << model;
    EXPECT_NEAR(sq_z / n / scaled(2, 2), 1.0, 0.05) << model;
  }
}

TEST(HinfOptions, BadValuesAreRejectedByName) {
  FilterOptions options;
  options.variant = "hinf_fastslam";
  EXPECT_EQ(createFilter(options)->variant(), "hinf_fastslam");
  options.hinf.gamma_heading = 0.0;
  try {
    createFilter(options);
    FAIL() << "gamma_heading 0 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("hinf.gamma_heading"), std::string::npos) << e.what();
  }
  options.hinf.gamma_heading = 1.0;
  options.hinf.gain = "kalman";
  EXPECT_THROW(createFilter(options), std::invalid_argument);
  options.hinf.gain = "prior";
  options.hinf.gamma_landmark = NAN;
  EXPECT_THROW(createFilter(options), std::invalid_argument);
  options.hinf.gamma_landmark = 1.0;
  options.hinf.theta_pose = 1.0;  // removes all the prior information: no solution
  EXPECT_THROW(createFilter(options), std::invalid_argument);
  options.hinf.theta_pose = 0.5;
  options.hinf.mode = "scaled";
  EXPECT_THROW(createFilter(options), std::invalid_argument);
  options.hinf.mode = "adaptive";
  options.hinf.adapt_steps = 0;
  try {
    createFilter(options);
    FAIL() << "adapt_steps 0 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("hinf.adapt_steps"), std::string::npos) << e.what();
  }
}

/// Point landmarks on a 30 m x 30 m square, seen from a robot driving a circle
/// of radius 8 m.
struct PointWorld {
  std::vector<Eigen::Vector2d> landmarks;
  PointWorld() {
    for (int i = 0; i < 16; ++i) {
      const double a = 2.0 * M_PI * i / 16.0;
      landmarks.emplace_back((i % 2 ? 5.0 : 11.0) * std::cos(a),
                             (i % 2 ? 5.0 : 11.0) * std::sin(a));
    }
  }
  FeatureSet observe(const Pose2& pose, Rng& rng, double sigma_r, double sigma_b, double reported_r,
                     double reported_b) const {
    FeatureSet set;
    for (size_t i = 0; i < landmarks.size(); ++i) {
      const Eigen::Vector2d d = landmarks[i] - pose.head<2>();
      const double bearing = wrapAngle(std::atan2(d.y(), d.x()) - pose.z());
      if (d.norm() > 8.0 || std::fabs(bearing) > M_PI / 2) continue;
      PointFeature f;
      f.range = d.norm() + sampleGaussian(rng, sigma_r);
      f.bearing = wrapAngle(bearing + sampleGaussian(rng, sigma_b));
      f.covariance << reported_r * reported_r, 0.0, 0.0, reported_b * reported_b;
      f.id = static_cast<int>(i);
      set.points.push_back(f);
    }
    return set;
  }
};

struct RunResult {
  double ate = 0.0;       // RMSE of the estimate's position over the run, unaligned
  double odom_ate = 0.0;  // same for dead reckoning
  long fallbacks = 0;
  bool finite = true;
  double attenuation = 0.0;  // the filter's theta at the end
};

/// Drives 1.5 circles with noisy odometry; the filter is told `reported`
/// sigmas.
RunResult runCircle(const FilterOptions& options, unsigned seed, double reported_r,
                    double reported_b) {
  PointWorld world;
  std::unique_ptr<SlamFilter> filter = createFilter(options);
  Rng rng(seed);
  Pose2 truth(8.0, 0.0, M_PI / 2), odom = truth;
  filter->reset(truth);
  RunResult result;
  double sq = 0.0, odom_sq = 0.0;
  const int steps = 450;
  for (int k = 0; k < steps; ++k) {
    const Pose2 delta(0.167, 0.0, 0.167 / 8.0);
    truth = compose(truth, delta);
    const Pose2 noisy(delta.x() + sampleGaussian(rng, 0.01), sampleGaussian(rng, 0.005),
                      delta.z() + sampleGaussian(rng, 0.01));
    odom = compose(odom, noisy);
    MotionInput motion;
    motion.delta = noisy;
    filter->predict(motion);
    const UpdateStats stats =
        filter->update(world.observe(truth, rng, 0.05, 0.002, reported_r, reported_b));
    result.fallbacks += stats.fallbacks;
    const Pose2 estimate = filter->estimate().mean;
    result.finite = result.finite && estimate.allFinite();
    sq += (estimate.head<2>() - truth.head<2>()).squaredNorm();
    odom_sq += (odom.head<2>() - truth.head<2>()).squaredNorm();
  }
  result.ate = std::sqrt(sq / steps);
  result.odom_ate = std::sqrt(odom_sq / steps);
  EXPECT_EQ(filter->stats().fallbacks, result.fallbacks);
  result.attenuation = filter->stats().attenuation;
  return result;
}

FilterOptions circleOptions(const std::string& variant) {
  FilterOptions options;
  options.variant = variant;
  options.particles = 30;
  options.seed = 4;
  options.use_lines = false;
  options.resample_threshold = 0.75;
  options.measurement.sigma_range_m = 1e-3;
  options.measurement.sigma_bearing_rad = 1e-4;
  options.motion.alpha1 = options.motion.alpha2 = 0.01;
  options.motion.alpha3 = options.motion.alpha4 = 0.01;
  options.motion.min_sigma_xy_m = 0.01;
  options.motion.min_sigma_theta_rad = 0.01;
  return options;
}

TEST(HinfFastSlam, ConvergesOnASimulatedLandmarkWorld) {
  const RunResult r = runCircle(circleOptions("hinf_fastslam"), 21, 0.05, 0.002);
  const RunResult f = runCircle(circleOptions("fastslam2"), 21, 0.05, 0.002);
  EXPECT_TRUE(r.finite);
  EXPECT_EQ(r.fallbacks, 0);
  EXPECT_LT(r.ate, 0.4) << "odometry " << r.odom_ate << ", FastSLAM 2.0 " << f.ate;
  EXPECT_LT(r.ate, 0.25 * r.odom_ate);
}

TEST(HinfFastSlam, StaysAccurateWhenTheMeasurementNoiseIsOverstated) {
  // Told 0.5 m / 0.05 rad while the truth is 0.05 m / 0.002 rad.
  const RunResult r = runCircle(circleOptions("hinf_fastslam"), 21, 0.5, 0.05);
  const RunResult f = runCircle(circleOptions("fastslam2"), 21, 0.5, 0.05);
  EXPECT_TRUE(r.finite);
  EXPECT_LT(r.ate, 0.5) << "odometry " << r.odom_ate << ", FastSLAM 2.0 " << f.ate;
  EXPECT_LT(r.ate, 0.3 * r.odom_ate);
  // And better than FastSLAM 2.0 told the same (0.23 against 0.35 m here): the test passed
  // with the variant set to fastslam2 before this check.
  EXPECT_LT(r.ate, 0.85 * f.ate);
}

// The filter feeds its innovations to the adaptive rule: told a measurement noise 10 x 25 times
// the truth (100 x 625 in variance) it learns a large attenuation and is then more accurate than
// FastSLAM 2.0 told the same; told the truth it stays close to the EKF.
TEST(HinfFastSlam, AdaptiveAttenuationLearnsAnOverstatedNoise) {
  FilterOptions options = circleOptions("hinf_fastslam");
  options.hinf.mode = "adaptive";
  options.hinf.theta_pose = 0.99;
  options.hinf.adapt_steps = 20;
  options.hinf.proposal_covariance = "ekf";
  const RunResult wrong = runCircle(options, 21, 0.5, 0.05);
  const RunResult right = runCircle(options, 21, 0.05, 0.002);
  const RunResult f = runCircle(circleOptions("fastslam2"), 21, 0.5, 0.05);
  EXPECT_TRUE(wrong.finite && right.finite);
  EXPECT_GT(wrong.attenuation, 0.9);
  EXPECT_LT(right.attenuation, 0.5);
  EXPECT_EQ(f.attenuation, 0.0);
  EXPECT_LT(wrong.ate, f.ate) << "odometry " << wrong.odom_ate;
}

TEST(HinfFastSlam, CountsFallbacksAndNeverPublishesNaN) {
  FilterOptions options = circleOptions("hinf_fastslam");
  options.hinf.mode = "absolute";
  options.hinf.gamma_landmark = 1e-9;  // 1 / gamma beyond any landmark's information
  options.hinf.gamma_position = options.hinf.gamma_heading = 1e-9;
  const RunResult r = runCircle(options, 5, 0.05, 0.002);
  EXPECT_TRUE(r.finite);
  EXPECT_GT(r.fallbacks, 0);
  EXPECT_LT(r.ate, 0.5 * r.odom_ate);  // it is FastSLAM 2.0 then
  options.hinf.gamma_landmark = options.hinf.gamma_position = INFINITY;
  options.hinf.gamma_heading = INFINITY;
  EXPECT_EQ(runCircle(options, 5, 0.05, 0.002).fallbacks, 0);
}

TEST(HinfFastSlam, InfiniteGammaWithMarginalWeightsIsFastSlam2) {
  FilterOptions options = circleOptions("hinf_fastslam");
  options.hinf.mode = "absolute";
  options.hinf.gamma_landmark = options.hinf.gamma_position = INFINITY;
  options.hinf.gamma_heading = INFINITY;
  options.hinf.weight = "marginal";
  const RunResult hinf = runCircle(options, 9, 0.05, 0.002);
  options.hinf.mode = "relative";  // theta 0: the EKF as well
  options.hinf.theta_pose = options.hinf.theta_landmark = 0.0;
  const RunResult relative = runCircle(options, 9, 0.05, 0.002);
  options.variant = "fastslam2";
  const RunResult fastslam = runCircle(options, 9, 0.05, 0.002);
  EXPECT_DOUBLE_EQ(hinf.ate, fastslam.ate);
  EXPECT_DOUBLE_EQ(relative.ate, fastslam.ate);
}

// Each new landmark of a step starts at its own observation, whatever the rule's weight scale
// (a shadowed index once made every new landmark of a step copy observation
// int(weightNoiseScale()), i.e. observation 1 for FastSLAM 2.0).
TEST(HinfFastSlam, NewLandmarksOfAStepStartAtTheirOwnObservations) {
  for (const std::string weight : {"marginal", "attenuated"}) {
    for (const std::string variant : {"fastslam2", "hinf_fastslam"}) {
      FilterOptions options = circleOptions(variant);
      options.particles = 5;
      options.hinf.mode = "relative";
      options.hinf.theta_pose = 0.8;
      options.hinf.weight = weight;
      std::unique_ptr<SlamFilter> filter = createFilter(options);
      filter->reset(Pose2::Zero());
      FeatureSet set;
      const std::vector<Eigen::Vector2d> points = {{3.0, 0.0}, {0.0, 4.0}, {-2.0, -2.0}};
      for (const Eigen::Vector2d& q : points) {
        PointFeature f;
        f.range = q.norm();
        f.bearing = std::atan2(q.y(), q.x());
        f.covariance = Eigen::Vector2d(1e-4, 1e-6).asDiagonal();
        set.points.push_back(f);  // id -1: the filter associates
      }
      filter->update(set);
      const std::vector<LandmarkEstimate> map = filter->landmarks();
      ASSERT_EQ(map.size(), points.size()) << variant << ", weight " << weight;
      for (const Eigen::Vector2d& q : points) {
        double nearest = INFINITY;
        for (const LandmarkEstimate& lm : map) nearest = std::min(nearest, (lm.mean - q).norm());
        EXPECT_LT(nearest, 0.05) << variant << ", weight " << weight << ": no landmark at ("
                                 << q.x() << ", " << q.y() << ")";
      }
    }
  }
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam
