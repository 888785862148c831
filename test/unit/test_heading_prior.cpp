#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/heading_prior.h"
#include "synthetic_world.h"

namespace rbpf_slam {
namespace core {
namespace {

// A line observation with this normal angle (base frame) and length.
Observation line(double theta, double length = 2.0) {
  Observation o;
  o.type = LandmarkType::kLine;
  o.z = Eigen::Vector2d(3.0, theta);
  o.start = Eigen::Vector2d(0.0, 0.0);
  o.end = Eigen::Vector2d(length, 0.0);
  return o;
}

HeadingPriorOptions given(double direction) {
  HeadingPriorOptions o;
  o.enabled = true;
  o.learn_direction = false;
  o.direction_rad = direction;
  return o;
}

TEST(HeadingPrior, AxisOffsetFoldsTheFourAxes) {
  EXPECT_NEAR(axisOffset(0.1), 0.1, 1e-12);
  EXPECT_NEAR(axisOffset(M_PI / 2 + 0.1), 0.1, 1e-12);
  EXPECT_NEAR(axisOffset(M_PI - 0.1), -0.1, 1e-12);
  EXPECT_NEAR(axisOffset(-M_PI + 0.05), 0.05, 1e-12);
  EXPECT_NEAR(axisOffset(-3 * M_PI / 2 - 0.2), -0.2, 1e-12);
  EXPECT_NEAR(axisOffset(M_PI / 4 + 0.01), -M_PI / 4 + 0.01, 1e-12);  // the nearer axis
}

TEST(HeadingPrior, LearnsTheDirectionOfARotatedBuilding) {
  HeadingPriorOptions options;
  options.enabled = true;
  options.learn_updates = 3;
  HeadingPrior prior(options);
  // Walls of a building turned by 0.4 rad, seen from heading 0.1: normals at 0.3 + k pi/2 in
  // the base frame; a diagonal wall and a short clutter line pull a little.
  const std::vector<Observation> seen{line(0.3), line(0.3 + M_PI / 2), line(0.3 - M_PI),
                                      line(0.3 + 0.6, 0.3), line(0.31, 4.0)};
  for (int k = 0; k < 2; ++k) {
    prior.learn(seen, 0.1);
    EXPECT_FALSE(prior.ready());
  }
  prior.learn({}, 0.1);  // an update without lines does not count
  EXPECT_FALSE(prior.ready());
  prior.learn(seen, 0.1);
  ASSERT_TRUE(prior.ready());
  EXPECT_NEAR(prior.direction(), 0.4, 0.01);
  // Learning stops once the direction is fixed; reset() forgets it.
  prior.learn({line(0.0)}, 0.0);
  EXPECT_NEAR(prior.direction(), 0.4, 0.01);
  prior.reset();
  EXPECT_FALSE(prior.ready());
}

// A building that is not rectilinear: walls at 0 and at 68 deg (axis offset -22 deg). The
// direction is the stronger family's, not a blend that neither family would match.
TEST(HeadingPrior, AnObliqueWallFamilyDoesNotPullTheDirection) {
  HeadingPriorOptions options;
  options.enabled = true;
  options.learn_updates = 1;
  HeadingPrior prior(options);
  const double oblique = 68.0 * M_PI / 180.0;
  prior.learn({line(0.0, 6.0), line(M_PI, 5.0), line(0.01, 2.0), line(oblique, 4.0),
               line(oblique + M_PI, 4.0), line(oblique - 0.01, 2.0)},
              0.0);
  ASSERT_TRUE(prior.ready());
  EXPECT_NEAR(prior.direction(), 2.0 * 0.01 / 13.0, 1e-9);
  double offset = 1.0;
  EXPECT_FALSE(prior.residual({line(oblique), line(oblique + M_PI)}, 0.0, &offset));
}

TEST(HeadingPrior, ResidualUsesAxisAlignedLinesOnly) {
  HeadingPrior prior(given(0.0));
  double offset = 0.0;
  // Two walls 0.02 rad off the axes at this heading, one diagonal wall ignored.
  const std::vector<Observation> seen{line(0.02), line(M_PI / 2 + 0.02), line(0.5)};
  ASSERT_TRUE(prior.residual(seen, 0.0, &offset));
  EXPECT_NEAR(offset, 0.02, 1e-12);
  ASSERT_TRUE(prior.residual(seen, -0.05, &offset));  // the heading moves every line
  EXPECT_NEAR(offset, -0.03, 1e-12);
  // One aligned line is fewer than min_lines (2); lines beyond the tolerance do not count.
  EXPECT_FALSE(prior.residual({line(0.02), line(0.5)}, 0.0, &offset));
  EXPECT_FALSE(prior.residual(seen, 0.2, &offset));
  // Off, or not yet learned: no measurement.
  HeadingPriorOptions off = given(0.0);
  off.enabled = false;
  EXPECT_FALSE(HeadingPrior(off).residual(seen, 0.0, &offset));
  HeadingPriorOptions learning;
  learning.enabled = true;
  EXPECT_FALSE(HeadingPrior(learning).residual(seen, 0.0, &offset));
}

TEST(HeadingPrior, ConditionIsTheKalmanUpdateOfTheHeading) {
  HeadingPriorOptions options = given(0.0);
  options.sigma_rad = 0.1;
  HeadingPrior prior(options);
  Pose2 mean(1.0, 2.0, 0.1);
  Eigen::Matrix3d cov;
  cov << 0.04, 0.0, 0.005, 0.0, 0.04, 0.0, 0.005, 0.0, 0.01;
  const double ll = prior.condition(0.1, &mean, &cov);  // measured heading 0.0
  // Equal variances: half-way; x moves with its correlation (gain 0.005 / 0.02).
  EXPECT_NEAR(mean.z(), 0.05, 1e-12);
  EXPECT_NEAR(mean.x(), 1.0 - 0.25 * 0.1, 1e-12);
  EXPECT_NEAR(mean.y(), 2.0, 1e-12);
  EXPECT_NEAR(cov(2, 2), 0.005, 1e-12);
  EXPECT_NEAR(cov(0, 0), 0.04 - 0.005 * 0.005 / 0.02, 1e-12);
  EXPECT_NEAR(ll, -0.5 * (0.01 / 0.02 + std::log(2 * M_PI * 0.02)), 1e-12);
}

TEST(HeadingPrior, OutOfRangeOptionsAreNamed) {
  HeadingPriorOptions o;
  o.tolerance_rad = M_PI / 4;
  try {
    validate(o);
    FAIL() << "tolerance pi/4 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("heading_prior.tolerance_rad"), std::string::npos);
  }
  o = HeadingPriorOptions();
  o.sigma_rad = 0.0;
  EXPECT_THROW(validate(o), std::invalid_argument);
  o = HeadingPriorOptions();
  o.min_lines = 0;
  EXPECT_THROW(validate(o), std::invalid_argument);
}

// Particles that start with a heading error (spread 0.04 rad around +0.06 rad) in an
// axis-aligned room: FastSLAM alone builds each particle's map at its own heading and keeps the
// error; with the prior, the walls' directions weigh the particles and the error goes.
double finalHeadingError(bool with_prior, long* measurements) {
  FilterOptions options;
  options.particles = 40;
  options.seed = 11;
  options.use_points = false;
  options.heading_prior = given(0.0);
  options.heading_prior.enabled = with_prior;
  FastSlam2 filter(options);
  SyntheticWorld world;
  Rng rng(5);
  Pose2 truth(-3.0, 0.0, 0.0);
  filter.reset(truth);
  filter.resetPose(Pose2(-3.0, 0.0, 0.06), Eigen::Vector3d(1e-4, 1e-4, 0.04 * 0.04).asDiagonal());
  for (int k = 0; k < 30; ++k) {
    const Pose2 delta(0.1, 0.0, 0.0);
    truth = compose(truth, delta);
    MotionInput motion;
    motion.delta = delta;
    filter.predict(motion);
    filter.update(world.observe(truth, rng, 0.01, 0.005));
  }
  *measurements = filter.stats().heading_measurements;
  return std::fabs(wrapAngle(filter.estimate().mean.z() - truth.z()));
}

TEST(HeadingPrior, FastSlamRecoversAStartHeadingErrorFromTheWalls) {
  long with_count = 0, without_count = 0;
  const double without = finalHeadingError(false, &without_count);
  const double with = finalHeadingError(true, &with_count);
  EXPECT_GT(without, 0.03);
  EXPECT_LT(with, 0.015);
  EXPECT_EQ(without_count, 0);
  EXPECT_GT(with_count, 0);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam
