#include "rbpf_slam/core/motion/motion_model.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {
namespace {

/// Variances of the diffusion added to every step, position and heading (before the noise
/// scale): the per-step floors plus a random walk growing with the step's duration.
double dtOf(const MotionInput& motion) {
  return std::isfinite(motion.dt) && motion.dt > 0.0 ? motion.dt : 0.0;
}
double floorVarianceXy(const MotionOptions& o, const MotionInput& motion) {
  return o.min_sigma_xy_m * o.min_sigma_xy_m +
         dtOf(motion) * o.sigma_xy_per_sqrt_s * o.sigma_xy_per_sqrt_s;
}
double floorVarianceTheta(const MotionOptions& o, const MotionInput& motion) {
  return o.min_sigma_theta_rad * o.min_sigma_theta_rad +
         dtOf(motion) * o.sigma_theta_per_sqrt_s * o.sigma_theta_per_sqrt_s;
}

/// Adds the floors and the random walk to a sampled pose, scaled by the step's noise scale as
/// the rest of the draw; floorCovariance() is their covariance before that scale.
void addFloorNoise(const MotionOptions& o, const MotionInput& motion, Rng& rng, Pose2* pose) {
  const double sigma_xy = std::sqrt(floorVarianceXy(o, motion));
  const double sigma_theta = std::sqrt(floorVarianceTheta(o, motion));
  pose->x() += sampleGaussian(rng, motion.noise_scale * sigma_xy);
  pose->y() += sampleGaussian(rng, motion.noise_scale * sigma_xy);
  pose->z() = wrapAngle(pose->z() + sampleGaussian(rng, motion.noise_scale * sigma_theta));
}
Eigen::Matrix3d floorCovariance(const MotionOptions& o, const MotionInput& motion) {
  const double xy = floorVarianceXy(o, motion);
  return Eigen::Vector3d(xy, xy, floorVarianceTheta(o, motion)).asDiagonal();
}

/// Odometry model of Thrun, Burgard & Fox (rot1, trans, rot2 with alpha noise).
class OdometryMotionModel : public MotionModel {
 public:
  explicit OdometryMotionModel(const MotionOptions& options) : options_(options) {}

  Pose2 sample(const Pose2& previous, const MotionInput& motion, Rng& rng) const override {
    double rot1, trans, rot2;
    decompose(motion.delta, &rot1, &trans, &rot2);
    const double k = motion.noise_scale;
    const double rot1_hat =
        rot1 - sampleGaussian(rng, k * std::sqrt(options_.alpha1 * rot1 * rot1 +
                                                 options_.alpha2 * trans * trans));
    const double trans_hat =
        trans - sampleGaussian(rng, k * std::sqrt(options_.alpha3 * trans * trans +
                                                  options_.alpha4 * (rot1 * rot1 + rot2 * rot2)));
    const double rot2_hat =
        rot2 - sampleGaussian(rng, k * std::sqrt(options_.alpha1 * rot2 * rot2 +
                                                 options_.alpha2 * trans * trans));
    const double heading = previous.z() + rot1_hat;
    Pose2 next(previous.x() + trans_hat * std::cos(heading),
               previous.y() + trans_hat * std::sin(heading),
               wrapAngle(previous.z() + rot1_hat + rot2_hat));
    addFloorNoise(options_, motion, rng, &next);
    return next;
  }

  Eigen::Matrix3d covariance(const Pose2& previous, const MotionInput& motion) const override {
    double rot1, trans, rot2;
    decompose(motion.delta, &rot1, &trans, &rot2);
    const Eigen::Vector3d variances(
        options_.alpha1 * rot1 * rot1 + options_.alpha2 * trans * trans,
        options_.alpha3 * trans * trans + options_.alpha4 * (rot1 * rot1 + rot2 * rot2),
        options_.alpha1 * rot2 * rot2 + options_.alpha2 * trans * trans);
    const double heading = previous.z() + rot1;
    // Jacobian of the new pose with respect to (rot1, trans, rot2).
    Eigen::Matrix3d v;
    v << -trans * std::sin(heading), std::cos(heading), 0.0,
        trans * std::cos(heading), std::sin(heading), 0.0,
        1.0, 0.0, 1.0;
    const Eigen::Matrix3d cov =
        v * variances.asDiagonal() * v.transpose() + floorCovariance(options_, motion);
    return motion.noise_scale * motion.noise_scale * cov;
  }

 private:
  static void decompose(const Pose2& delta, double* rot1, double* trans, double* rot2) {
    *trans = std::hypot(delta.x(), delta.y());
    // Below a millimetre the direction of travel is noise: treat it as a pure rotation.
    *rot1 = *trans < 1e-3 ? 0.0 : std::atan2(delta.y(), delta.x());
    // Driving backwards: keep rot1 small and make trans negative.
    if (std::fabs(*rot1) > M_PI / 2.0) {
      *rot1 = wrapAngle(*rot1 + M_PI);
      *trans = -*trans;
    }
    *rot2 = wrapAngle(delta.z() - *rot1);
  }

  const MotionOptions options_;
};

/// Differential-drive wheel model (Yatim & Buniyamin eqs. 11, 12): left and right wheel
/// travel recovered from the increment and perturbed with
/// sigma_l^2 = (alpha1 * l)^2 + (alpha2 * (l - r))^2 and likewise for r (wheelTravelSigmas).
class DiffDriveMotionModel : public MotionModel {
 public:
  explicit DiffDriveMotionModel(const MotionOptions& options) : options_(options) {}

  Pose2 sample(const Pose2& previous, const MotionInput& motion, Rng& rng) const override {
    double left, right, sigma_left, sigma_right;
    wheelTravel(motion.delta, options_.wheel_base_m, &left, &right);
    wheelTravelSigmas(left, right, options_.wheel_alpha1, options_.wheel_alpha2, &sigma_left,
                      &sigma_right);
    const double l = left + sampleGaussian(rng, motion.noise_scale * sigma_left);
    const double r = right + sampleGaussian(rng, motion.noise_scale * sigma_right);
    Pose2 next = integrate(previous, l, r);
    addFloorNoise(options_, motion, rng, &next);
    return next;
  }

  Eigen::Matrix3d covariance(const Pose2& previous, const MotionInput& motion) const override {
    double left, right, sigma_left, sigma_right;
    wheelTravel(motion.delta, options_.wheel_base_m, &left, &right);
    wheelTravelSigmas(left, right, options_.wheel_alpha1, options_.wheel_alpha2, &sigma_left,
                      &sigma_right);
    // Numerical Jacobian of the pose with respect to (l, r).
    Eigen::Matrix<double, 3, 2> j;
    const double h = 1e-6;
    const Pose2 base = integrate(previous, left, right);
    const Pose2 dl = integrate(previous, left + h, right);
    const Pose2 dr = integrate(previous, left, right + h);
    j.col(0) = (dl - base) / h;
    j.col(1) = (dr - base) / h;
    j(2, 0) = wrapAngle(dl.z() - base.z()) / h;
    j(2, 1) = wrapAngle(dr.z() - base.z()) / h;
    const Eigen::Vector2d variances(sigma_left * sigma_left, sigma_right * sigma_right);
    // The floors are scaled with the wheel noise, as in sample().
    const Eigen::Matrix3d cov =
        j * variances.asDiagonal() * j.transpose() + floorCovariance(options_, motion);
    return motion.noise_scale * motion.noise_scale * cov;
  }

 private:
  Pose2 integrate(const Pose2& previous, double l, double r) const {
    const double d = 0.5 * (l + r), dtheta = (r - l) / options_.wheel_base_m;
    const double heading = previous.z() + 0.5 * dtheta;
    return Pose2(previous.x() + d * std::cos(heading), previous.y() + d * std::sin(heading),
                 wrapAngle(previous.z() + dtheta));
  }

  const MotionOptions options_;
};

}  // namespace

void wheelTravel(const Pose2& delta, double wheel_base_m, double* left, double* right) {
  const double d = std::hypot(delta.x(), delta.y()) * (delta.x() < 0.0 ? -1.0 : 1.0);
  const double half = 0.5 * wheel_base_m * delta.z();
  *left = d - half;
  *right = d + half;
}

void wheelTravelSigmas(double left, double right, double alpha1, double alpha2,
                       double* sigma_left, double* sigma_right) {
  const double slip = alpha2 * (left - right);
  *sigma_left = std::sqrt(alpha1 * left * alpha1 * left + slip * slip);
  *sigma_right = std::sqrt(alpha1 * right * alpha1 * right + slip * slip);
}

void validate(const MotionOptions& options) {
  requireOneOf("motion.model", options.model, {"odometry", "diff_drive"});
  // Upper limits far beyond any real robot, to catch a misplaced digit.
  const auto check = [](const char* name, double value, double lo, double hi) {
    requireRange(std::string("motion.") + name, value, lo, hi);
  };
  check("alpha1", options.alpha1, 0.0, 10.0);
  check("alpha2", options.alpha2, 0.0, 10.0);
  check("alpha3", options.alpha3, 0.0, 10.0);
  check("alpha4", options.alpha4, 0.0, 10.0);
  check("wheel_base_m", options.wheel_base_m, 1e-3, 10.0);
  check("wheel_alpha1", options.wheel_alpha1, 0.0, 10.0);
  check("wheel_alpha2", options.wheel_alpha2, 0.0, 10.0);
  check("min_sigma_xy_m", options.min_sigma_xy_m, 0.0, 1.0);
  check("min_sigma_theta_rad", options.min_sigma_theta_rad, 0.0, 1.0);
  check("sigma_xy_per_sqrt_s", options.sigma_xy_per_sqrt_s, 0.0, 10.0);
  check("sigma_theta_per_sqrt_s", options.sigma_theta_per_sqrt_s, 0.0, 10.0);
}

std::unique_ptr<MotionModel> createMotionModel(const MotionOptions& options) {
  validate(options);
  if (options.model == "diff_drive") return std::make_unique<DiffDriveMotionModel>(options);
  return std::make_unique<OdometryMotionModel>(options);
}

void PendingMotion::add(const MotionInput& m) {
  if (!m.delta.allFinite()) return;
  if (!has_motion) {
    motion = m;
    has_motion = true;
    return;
  }
  motion.delta = compose(motion.delta, m.delta);
  motion.dt += m.dt;
  motion.stamp = m.stamp;
  motion.noise_scale = std::max(motion.noise_scale, m.noise_scale);
}

MotionInput PendingMotion::take() {
  const MotionInput m = has_motion ? motion : MotionInput();
  *this = PendingMotion();
  return m;
}

}  // namespace core
}  // namespace rbpf_slam
