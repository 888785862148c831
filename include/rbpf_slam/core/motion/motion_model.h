#pragma once
// Motion models: sample a new pose from an odometry increment, and give its Gaussian
// approximation for the FastSLAM 2.0 proposal.

#include <Eigen/Core>
#include <memory>
#include <string>

#include "rbpf_slam/core/geometry.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {

/// What the robot reported it did between two filter steps.
struct MotionInput {
  double stamp = 0.0;          // s, time of the new pose
  double dt = 0.0;             // s since the previous step
  Pose2 delta = Pose2::Zero(); // odometry increment, expressed in the previous base frame
  double noise_scale = 1.0;    // multiplies the model's sigmas (< 1: laser-corrected increment)
};

/// The motion not yet applied by an update: several predict() calls before one update
/// compose (deltas compose, durations add, the larger noise scale wins); a non-finite step
/// is ignored. Every filter variant keeps one.
struct PendingMotion {
  bool has_motion = false;
  MotionInput motion;
  void add(const MotionInput& m);
  /// The accumulated motion (a zero one if none) and forget it.
  MotionInput take();
};

/// Options of every motion model (unused fields are ignored by a model).
struct MotionOptions {
  std::string model = "odometry";  // odometry | diff_drive
  // odometry (Thrun et al., rot1-trans-rot2): variances grow with motion.
  double alpha1 = 0.05;  // rot noise from rot   [rad^2/rad^2]
  double alpha2 = 0.01;  // rot noise from trans [rad^2/m^2]
  double alpha3 = 0.05;  // trans noise from trans [m^2/m^2]
  double alpha4 = 0.01;  // trans noise from rot [m^2/rad^2]
  // diff_drive (Yatim & Buniyamin eqs. 11, 12): wheel travel noise.
  double wheel_base_m = 0.33;
  double wheel_alpha1 = 0.03;  // sigma per metre of that wheel's travel
  double wheel_alpha2 = 0.03;  // sigma per metre of wheel travel difference
  // Floors so that a stationary robot keeps a little diffusion.
  double min_sigma_xy_m = 0.002;
  double min_sigma_theta_rad = 0.001;
  // Random walk with the step's duration (MotionInput::dt): variance dt * sigma^2 added to the
  // floors above. Unlike the alphas, which see only the net increment between two filter
  // steps, it keeps growing while the robot goes unobserved and wanders (e.g. tens of seconds
  // between landmark sightings). 0: off.
  double sigma_xy_per_sqrt_s = 0.0;      // m / sqrt(s)
  double sigma_theta_per_sqrt_s = 0.0;   // rad / sqrt(s)
};

/// A probabilistic motion model p(x_t | x_{t-1}, u_t).
class MotionModel {
 public:
  virtual ~MotionModel() = default;
  /// Draws x_t given x_{t-1}.
  virtual Pose2 sample(const Pose2& previous, const MotionInput& motion, Rng& rng) const = 0;
  /// Mean of x_t (the noise-free composition).
  Pose2 mean(const Pose2& previous, const MotionInput& motion) const {
    return compose(previous, motion.delta);
  }
  /// Covariance of x_t in the map frame, linearised at the mean.
  virtual Eigen::Matrix3d covariance(const Pose2& previous, const MotionInput& motion) const = 0;
};

/// Left and right wheel travel of a differential drive with this wheel base that moved by
/// delta (eq. 11 inverted: d = (l + r) / 2 along the chord, dtheta = (r - l) / b).
void wheelTravel(const Pose2& delta, double wheel_base_m, double* left, double* right);
/// Eq. 12: sigma_l^2 = (alpha1 l)^2 + (alpha2 (l - r))^2, sigma_r^2 = (alpha1 r)^2 + (...)^2.
void wheelTravelSigmas(double left, double right, double alpha1, double alpha2,
                       double* sigma_left, double* sigma_right);

/// Builds the model named by options.model; throws std::invalid_argument for unknown names.
std::unique_ptr<MotionModel> createMotionModel(const MotionOptions& options);

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const MotionOptions& options);

}  // namespace core
}  // namespace rbpf_slam
