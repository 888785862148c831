#include "rbpf_slam/core/filters/ekf_slam.h"

#include <Eigen/Dense>
#include <cmath>

#include "rbpf_slam/core/filters/landmark_map.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {
namespace {

Eigen::Matrix2d symmetric(const Eigen::Matrix2d& m) { return 0.5 * (m + m.transpose()); }

}  // namespace

EkfSlam::EkfSlam(const FilterOptions& options)
    : options_(options), motion_model_(createMotionModel(options.motion)) {
  reset(Pose2::Zero());
}

void EkfSlam::reset(const Pose2& initial_pose) {
  state_ = initial_pose;
  covariance_ = Eigen::Matrix3d::Identity() * 1e-9;
  info_.clear();
  pending_motion_ = PendingMotion();
  next_landmark_id_ = 0;
  stats_ = FilterStats();
}

void EkfSlam::predict(const MotionInput& motion) {
  ++stats_.predictions;
  pending_motion_.add(motion);
}

void EkfSlam::applyMotion() {
  if (!pending_motion_.has_motion) return;
  const MotionInput motion = pending_motion_.take();
  const Pose2 previous = pose();
  const Pose2& d = motion.delta;
  const double c = std::cos(previous.z()), s = std::sin(previous.z());
  Eigen::Matrix3d f = Eigen::Matrix3d::Identity();  // d compose(previous, d) / d previous
  f(0, 2) = -s * d.x() - c * d.y();
  f(1, 2) = c * d.x() - s * d.y();
  const Eigen::Matrix3d q = motion_model_->covariance(previous, motion);
  state_.head<3>() = compose(previous, d);
  const int n = state_.size();
  covariance_.topLeftCorner<3, 3>() = f * covariance_.topLeftCorner<3, 3>() * f.transpose() + q;
  if (n > 3) {
    covariance_.topRightCorner(3, n - 3) = f * covariance_.topRightCorner(3, n - 3);
    covariance_.bottomLeftCorner(n - 3, 3) = covariance_.topRightCorner(3, n - 3).transpose();
  }
}

GlobalFeature EkfSlam::inMap(const Observation& o, const Pose2& at, int source) const {
  LineFeature line;  // the extent (and, for a line too short to have one, its normal form)
  line.rho = o.z.x();
  line.theta = o.z.y();
  line.start = o.start;
  line.end = o.end;
  return globalFeature(o.type, line, o.z, at, source);
}

UpdateStats EkfSlam::update(const FeatureSet& features) {
  UpdateStats stats;
  stats.neff = 1.0;
  stats.features_in = features.lines.size() + features.points.size();
  applyMotion();
  const std::vector<Observation> observations =
      prepareObservations(features, options_, &stats.features_rejected);
  std::vector<GlobalFeature> global;
  for (int j = 0; j < static_cast<int>(observations.size()); ++j) {
    global.push_back(inMap(observations[j], pose(), j));
  }
  std::vector<LandmarkType> types;
  std::vector<Eigen::Vector2d> means;
  for (int i = 0; i < landmarkCount(); ++i) {
    types.push_back(info_[i].type);
    means.push_back(state_.segment<2>(3 + 2 * i));
  }
  const WadAssociation a = associateByWad(global, types, means, options_.line_association,
                                          wadCentre(options_.line_association, pose().head<2>()));
  for (int i = 0; i < static_cast<int>(a.map_to_feature.size()); ++i) {
    // M_phi_z may give one feature to several landmarks; the EKF uses each feature once, on
    // the landmark it is most similar to, or it would count the same measurement twice.
    const int j = a.map_to_feature[i];
    if (j < 0 || a.feature_to_map[j] != i) continue;
    if (correct(i, observations[j])) {
      ++stats.associated;
      extendLine(i, inMap(observations[j], pose(), j));
    } else {
      ++stats.fallbacks;
    }
  }
  // New obstacles, at the corrected pose; one per group of similar features of this scan.
  std::vector<GlobalFeature> added;
  // augment() leaves the pose as it is: one centre for the whole loop.
  const Eigen::Vector2d centre = wadCentre(options_.line_association, pose().head<2>());
  for (int j : a.new_features) {
    const GlobalFeature g = inMap(observations[j], pose(), j);
    bool duplicate = false;
    for (const auto& other : added) {
      duplicate = duplicate ||
                  (other.type == g.type &&
                   featureDissimilarity(g.type, g.value, other.value, options_.line_association,
                                        centre) <
                       options_.line_association.h_similar_feature);
    }
    if (duplicate) continue;
    augment(observations[j], g);
    added.push_back(g);
    ++stats.new_landmarks;
  }
  ++stats_.updates;
  stats_.fallbacks += stats.fallbacks;
  stats_.last_neff = 1.0;
  stats_.landmarks = landmarkCount();
  return stats;
}

bool EkfSlam::correct(int i, const Observation& o) {
  const int k = 3 + 2 * i;
  const Eigen::Vector2d landmark = state_.segment<2>(k);
  const Prediction p = o.type == LandmarkType::kLine ? predictLine(pose(), landmark, o.z.y())
                                                     : predictPoint(pose(), landmark);
  const Eigen::Vector2d v = innovation(o.z, p.z);
  // P H^T with H nonzero only in the pose and landmark columns: O(n).
  const Eigen::MatrixXd pht = covariance_.leftCols<3>() * p.h_pose.transpose() +
                              covariance_.middleCols<2>(k) * p.h_landmark.transpose();
  Eigen::Matrix2d s = p.h_pose * pht.topRows<3>() + p.h_landmark * pht.middleRows<2>(k) + o.noise;
  s = symmetric(s);
  if (!finitePositiveDefinite(s)) return false;
  const Eigen::Matrix2d s_inv = s.inverse();
  const double gate = options_.ekf.innovation_gate_chi2;
  if (gate > 0.0 && v.dot(s_inv * v) > gate) return false;
  const Eigen::MatrixXd gain = pht * s_inv;
  const Eigen::VectorXd dx = gain * v;
  if (!dx.allFinite()) return false;
  state_ += dx;
  covariance_ -= gain * pht.transpose();  // P - K S K^T: the O(n^2) step
  // eval(): Eigen would read the transpose while writing it (aliasing), leaving it asymmetric.
  covariance_ = (0.5 * (covariance_ + covariance_.transpose())).eval();
  state_(2) = wrapAngle(state_(2));
  if (o.type == LandmarkType::kLine) {
    if (state_(k) < 0.0) {  // keep rho >= 0: flip the normal, and the rho row and column
      state_(k) = -state_(k);
      state_(k + 1) += M_PI;
      covariance_.row(k) *= -1.0;
      covariance_.col(k) *= -1.0;
      reverseExtent(&info_[i].extent_min, &info_[i].extent_max);
    }
    state_(k + 1) = wrapAngle(state_(k + 1));
  }
  ++info_[i].observations;
  return true;
}

void EkfSlam::augment(const Observation& o, const GlobalFeature& g) {
  const Pose2 at = pose();
  Eigen::Matrix2d jz;
  Eigen::Matrix<double, 2, 3> jp = Eigen::Matrix<double, 2, 3>::Zero();
  Eigen::Vector2d mean;
  if (o.type == LandmarkType::kLine) {
    // lineFromObservation: alpha = theta + phi, rho = rho_r + x cos(alpha) + y sin(alpha).
    mean = lineFromObservation(at, o.z, &jz);
    const double alpha = wrapAngle(o.z.y() + at.z());
    const double c = std::cos(alpha), s = std::sin(alpha);
    const double sign = jz(0, 0) < 0.0 ? -1.0 : 1.0;  // the normal was flipped
    jp << sign * c, sign * s, sign * (-at.x() * s + at.y() * c), 0.0, 0.0, 1.0;
  } else {
    mean = pointFromObservation(at, o.z, &jz);
    const double angle = at.z() + o.z.y();
    jp << 1.0, 0.0, -o.z.x() * std::sin(angle), 0.0, 1.0, o.z.x() * std::cos(angle);
  }
  appendLandmark(mean, jz * o.noise * jz.transpose(), jp, true);
  LandmarkInfo info;
  info.id = next_landmark_id_++;
  info.type = o.type;
  info_.push_back(info);
  info_.back().observations = 1;
  if (o.type == LandmarkType::kLine) {
    const Eigen::Vector2d line = state_.tail<2>();
    const double a = alongLine(line, g.start), b = alongLine(line, g.end);
    info_.back().extent_min = std::min(a, b);
    info_.back().extent_max = std::max(a, b);
  }
}

void EkfSlam::appendLandmark(const Eigen::Vector2d& mean, const Eigen::Matrix2d& cov,
                             const Eigen::Matrix<double, 2, 3>& jp, bool correlated) {
  const int n = state_.size();
  state_.conservativeResize(n + 2);
  state_.tail<2>() = mean;
  covariance_.conservativeResize(n + 2, n + 2);
  if (correlated) {
    const Eigen::MatrixXd cross = jp * covariance_.topLeftCorner(3, n);  // 2 x n
    covariance_.bottomLeftCorner(2, n) = cross;
    covariance_.topRightCorner(n, 2) = cross.transpose();
    covariance_.bottomRightCorner<2, 2>() =
        jp * covariance_.topLeftCorner<3, 3>() * jp.transpose() + cov;
  } else {
    covariance_.bottomLeftCorner(2, n).setZero();
    covariance_.topRightCorner(n, 2).setZero();
    covariance_.bottomRightCorner<2, 2>() = cov;
  }
}

void EkfSlam::extendLine(int i, const GlobalFeature& g) {
  if (info_[i].type != LandmarkType::kLine) return;
  const Eigen::Vector2d line = state_.segment<2>(3 + 2 * i);
  const double a = alongLine(line, g.start), b = alongLine(line, g.end);
  info_[i].extent_min = std::min({info_[i].extent_min, a, b});
  info_[i].extent_max = std::max({info_[i].extent_max, a, b});
}

PoseEstimate EkfSlam::estimate() const {
  PoseEstimate e;
  e.mean = pose();
  e.covariance = covariance_.topLeftCorner<3, 3>();
  return e;
}

std::vector<LandmarkEstimate> EkfSlam::landmarks() const {
  std::vector<LandmarkEstimate> out;
  for (int i = 0; i < landmarkCount(); ++i) {
    LandmarkEstimate e;
    e.id = info_[i].id;
    e.type = info_[i].type;
    e.mean = state_.segment<2>(3 + 2 * i);
    e.covariance = covariance_.block<2, 2>(3 + 2 * i, 3 + 2 * i);
    e.observations = info_[i].observations;
    if (e.type == LandmarkType::kLine) {
      e.start = pointOnLine(e.mean, info_[i].extent_min);
      e.end = pointOnLine(e.mean, info_[i].extent_max);
    } else {
      e.start = e.end = e.mean;
    }
    out.push_back(e);
  }
  return out;
}

std::vector<WeightedPose> EkfSlam::particles() const { return {{pose(), 1.0}}; }

FilterStats EkfSlam::stats() const { return stats_; }

bool EkfSlam::resetPose(const Pose2& new_pose, const Eigen::Matrix3d& cov) {
  if (!new_pose.allFinite() || !poseCovarianceUsable(cov)) return false;
  state_.head<3>() = new_pose;
  state_(2) = wrapAngle(state_(2));
  const int n = state_.size();
  covariance_.topLeftCorner<3, 3>() = 0.5 * (cov + cov.transpose());
  covariance_.topRightCorner(3, n - 3).setZero();
  covariance_.bottomLeftCorner(n - 3, 3).setZero();
  pending_motion_ = PendingMotion();
  return true;
}

bool EkfSlam::loadMap(const std::vector<LandmarkEstimate>& landmarks) {
  const Pose2 at = pose();
  const Eigen::Matrix3d pose_cov = covariance_.topLeftCorner<3, 3>();
  state_ = at;
  covariance_ = pose_cov;
  info_.clear();
  for (const auto& l : landmarks) {
    if (!l.mean.allFinite()) continue;
    const Eigen::Matrix2d cov = finitePositiveDefinite(symmetric(l.covariance))
                                    ? symmetric(l.covariance)
                                    : Eigen::Matrix2d::Identity() * 1e-4;
    appendLandmark(l.mean, cov, Eigen::Matrix<double, 2, 3>::Zero(), false);
    LandmarkInfo info;
    info.id = l.id;
    info.type = l.type;
    info.observations = std::max(l.observations, 1);
    if (l.type == LandmarkType::kLine) {
      const double a = alongLine(l.mean, l.start), b = alongLine(l.mean, l.end);
      info.extent_min = std::min(a, b);
      info.extent_max = std::max(a, b);
    }
    info_.push_back(info);
    next_landmark_id_ = std::max(next_landmark_id_, l.id + 1);
  }
  stats_.landmarks = landmarkCount();
  return true;
}

}  // namespace core
}  // namespace rbpf_slam
