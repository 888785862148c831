#include "rbpf_slam/core/filters/multifilter_smc.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "rbpf_slam/core/filters/landmark_map.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/filters/observation.h"
#include "rbpf_slam/core/filters/pose_moments.h"
#include "rbpf_slam/core/filters/resampling.h"

namespace rbpf_slam {
namespace core {

PoseEstimate weightedPoseMean(const std::vector<Pose2>& poses, const std::vector<double>& weights) {
  double total = 0.0;
  for (double w : weights) total += w;
  if (!(total > 0.0)) return PoseEstimate();
  std::vector<double> normalised(weights.size());
  for (size_t i = 0; i < weights.size(); ++i) normalised[i] = weights[i] / total;
  PoseEstimate e = poseMoments(poses, normalised);
  e.covariance += 1e-9 * Eigen::Matrix3d::Identity();
  return e;
}

// ---------------------------------------------------------------- landmark filter (Psi_i)

LandmarkParticleFilter::LandmarkParticleFilter(int id, LandmarkType type,
                                               const Eigen::Vector2d& detection,
                                               const Eigen::Vector2d& sigma, int particles,
                                               Rng& rng, const Eigen::Vector2d& seen_from)
    : id_(id), type_(type) {
  // Line particles keep the detection's normal direction (theta within pi/2 of it) and a
  // signed rho, so that a line through the origin does not split into two normal forms.
  particles_.resize(std::max(particles, 1));
  const bool line = type == LandmarkType::kLine;
  const Eigen::Vector2d local = line ? lineSeenFrom(detection, seen_from) : detection;
  for (auto& p : particles_) {
    // One statement per draw: the order of a constructor's arguments is the compiler's choice.
    const double b = sampleGaussian(rng, sigma.y());
    const double a = sampleGaussian(rng, sigma.x());
    p = local + Eigen::Vector2d(a, b);
    if (line) p = lineSeenFrom(p, -seen_from);  // rho measured from the origin again
  }
  computeCentroid();
}

void LandmarkParticleFilter::redraw(const Eigen::Vector2d& mean, const Eigen::Matrix2d& covariance,
                                    Rng& rng) {
  // A saved covariance may be a little asymmetric or indefinite from its printed digits (a
  // strongly correlated line's): symmetrised and its negative eigenvalues set to zero. Not
  // finite (a hand-edited map): no spread.
  Eigen::Matrix2d usable = Eigen::Matrix2d::Zero();
  if (covariance.allFinite()) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(
        (0.5 * (covariance + covariance.transpose())).eval());
    const Eigen::Vector2d values = eigen.eigenvalues().cwiseMax(0.0);
    usable = eigen.eigenvectors() * values.asDiagonal() * eigen.eigenvectors().transpose();
  }
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (auto& p : particles_) {
    p = usable.isZero(0.0) ? mean : sampleMultivariate<2>(rng, mean, usable);
    sum += p;
  }
  // Re-centred on the mean exactly: the map saved is the map loaded.
  const Eigen::Vector2d offset = sum / particles_.size() - mean;
  for (auto& p : particles_) p -= offset;
  computeCentroid();
}

bool LandmarkParticleFilter::update(const Eigen::Vector2d& observed,
                                    const Eigen::Vector2d& seen_from,
                                    const WadAssociationOptions& association,
                                    const MultiFilterOptions& options, Rng& rng) {
  const int n = particles_.size();
  std::vector<double> log_weights(n);
  for (int i = 0; i < n; ++i) {
    // Laplace likelihood of the dissimilarity (the paper's perceptual model, parameter c_m2).
    log_weights[i] =
        -featureDissimilarity(type_, particles_[i], observed, association, seen_from) /
        options.c_m2;
  }
  std::vector<double> weights;
  if (!normalizeLogWeights(log_weights, &weights)) return false;
  const std::vector<int> drawn = resampleLowVariance(weights, n, rng);
  std::vector<Eigen::Vector2d> next(n);
  const double jitter_b =
      type_ == LandmarkType::kLine ? options.roughening_rad : options.roughening_m;
  for (int i = 0; i < n; ++i) {
    const double b = sampleGaussian(rng, jitter_b);  // one statement per draw, as above
    const double a = sampleGaussian(rng, options.roughening_m);
    next[i] = particles_[drawn[i]] + Eigen::Vector2d(a, b);
  }
  particles_.swap(next);
  computeCentroid();
  ++observations_;
  return true;
}

void LandmarkParticleFilter::computeCentroid() {
  const double n = particles_.size();
  if (type_ == LandmarkType::kPoint) {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    for (const auto& p : particles_) sum += p;
    centroid_ = sum / n;
    return;
  }
  // Signed form around the first particle's normal, averaged, then brought to rho >= 0.
  const double reference = particles_.front().y();
  double rho = 0.0, theta = 0.0;
  for (const auto& p : particles_) {
    double d = wrapAngle(p.y() - reference), r = p.x();
    if (std::fabs(d) > M_PI / 2) {
      d = wrapAngle(d + M_PI);
      r = -r;
    }
    rho += r;
    theta += d;
  }
  rho /= n;
  theta = reference + theta / n;
  normalizeLine(rho, theta);
  // A centroid whose normal turned over (the mean signed rho changed sign) counts positions
  // along the line the other way: the extent turns with it.
  if (has_extent_ && std::fabs(wrapAngle(theta - centroid_.y())) > M_PI / 2) {
    reverseExtent(&extent_min_, &extent_max_);
  }
  centroid_ << rho, theta;
}

Eigen::Matrix2d LandmarkParticleFilter::covariance() const {
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  for (const auto& p : particles_) {
    const Eigen::Vector2d d = type_ == LandmarkType::kLine ? lineDifference(p, centroid_)
                                                           : Eigen::Vector2d(p - centroid_);
    cov += d * d.transpose();
  }
  return cov / particles_.size() + 1e-9 * Eigen::Matrix2d::Identity();
}

void LandmarkParticleFilter::extendBy(const Eigen::Vector2d& start, const Eigen::Vector2d& end) {
  if (type_ != LandmarkType::kLine) return;
  const double a = alongLine(centroid_, start), b = alongLine(centroid_, end);
  if (!has_extent_) {
    extent_min_ = std::min(a, b);
    extent_max_ = std::max(a, b);
    has_extent_ = true;
    return;
  }
  extent_min_ = std::min({extent_min_, a, b});
  extent_max_ = std::max({extent_max_, a, b});
}

LandmarkEstimate LandmarkParticleFilter::toEstimate() const {
  LandmarkEstimate e;
  e.id = id_;
  e.type = type_;
  e.mean = centroid_;
  e.covariance = covariance();
  e.observations = observations_;
  if (type_ == LandmarkType::kLine) {
    e.start = pointOnLine(centroid_, extent_min_);
    e.end = pointOnLine(centroid_, extent_max_);
  } else {
    e.start = e.end = centroid_;
  }
  return e;
}

// ---------------------------------------------------------------- the multi-filter SLAM

MultiFilterSmc::MultiFilterSmc(const FilterOptions& options)
    : options_(options), motion_model_(createMotionModel(options.motion)), rng_(options.seed) {
  reset(Pose2::Zero());
}

void MultiFilterSmc::reset(const Pose2& initial_pose) {
  // All particles at the start pose: SLAM fixes the map frame there (the paper's "arbitrary
  // starting point").
  robot_.assign(options_.particles, initial_pose);
  weights_.assign(robot_.size(), 1.0 / robot_.size());
  filters_.clear();
  pending_motion_ = PendingMotion();
  next_landmark_id_ = 0;
  stats_ = FilterStats();
}

void MultiFilterSmc::predict(const MotionInput& motion) {
  ++stats_.predictions;
  pending_motion_.add(motion);
}

std::vector<MultiFilterSmc::LocalFeature> MultiFilterSmc::prepare(const FeatureSet& features,
                                                                  int* rejected) const {
  std::vector<LocalFeature> out;
  forEachUsableFeature(
      features, options_.use_lines, options_.use_points, rejected,
      [&](const LineFeature& line) {
        LocalFeature f;
        f.type = LandmarkType::kLine;
        f.line = line;
        out.push_back(f);
      },
      [&](const PointFeature& point) {
        LocalFeature f;
        f.type = LandmarkType::kPoint;
        f.range_bearing << point.range, point.bearing;
        out.push_back(f);
      });
  return out;
}

GlobalFeature MultiFilterSmc::inMap(const LocalFeature& feature, const Pose2& pose,
                                    int source) const {
  return globalFeature(feature.type, feature.line, feature.range_bearing, pose, source);
}

UpdateStats MultiFilterSmc::update(const FeatureSet& features) {
  UpdateStats stats;
  stats.features_in = features.lines.size() + features.points.size();
  const std::vector<LocalFeature> local = prepare(features, &stats.features_rejected);
  updateRobot(local, &stats);
  updateMap(local, &stats);
  ++stats_.updates;
  stats_.last_neff = stats.neff;
  stats_.weight_resets += stats.weight_resets;
  stats_.landmarks = filters_.size();
  return stats;
}

void MultiFilterSmc::updateRobot(const std::vector<LocalFeature>& features, UpdateStats* stats) {
  const int n = robot_.size();
  if (pending_motion_.has_motion) {
    const MotionInput motion = pending_motion_.take();
    for (auto& pose : robot_) pose = motion_model_->sample(pose, motion, rng_);
  }
  stats->neff = effectiveSampleSize(weights_);
  if (features.empty() || filters_.empty()) return;

  // Candidate landmarks per feature at the predicted mean pose: those within twice the
  // similarity threshold. Each particle then takes the nearest candidate, its dissimilarity
  // capped at the threshold, so a feature that no landmark explains costs every particle the
  // same. Only features with a candidate count (the paper's "observed line obstacles").
  const Pose2 predicted = weightedPoseMean(robot_, weights_).mean;
  const double h = options_.line_association.h_similar_feature;
  const Eigen::Vector2d predicted_centre = wadCentre(options_.line_association, predicted.head<2>());
  std::vector<int> observed;
  std::vector<std::vector<int>> candidates;
  for (int j = 0; j < static_cast<int>(features.size()); ++j) {
    const GlobalFeature g = inMap(features[j], predicted, j);
    std::vector<int> near;
    for (int i = 0; i < static_cast<int>(filters_.size()); ++i) {
      if (filters_[i].type() != g.type) continue;
      if (featureDissimilarity(g.type, g.value, filters_[i].centroid(), options_.line_association,
                               predicted_centre) < 2.0 * h) {
        near.push_back(i);
      }
    }
    if (near.empty()) continue;
    observed.push_back(j);
    candidates.push_back(std::move(near));
  }
  if (observed.empty()) return;

  std::vector<double> log_weights(n);
  for (int p = 0; p < n; ++p) {
    double sum = 0.0;
    const Eigen::Vector2d centre = wadCentre(options_.line_association, robot_[p].head<2>());
    for (size_t k = 0; k < observed.size(); ++k) {
      const GlobalFeature g = inMap(features[observed[k]], robot_[p], observed[k]);
      double best = h;
      for (int i : candidates[k]) {
        best = std::min(best, featureDissimilarity(g.type, g.value, filters_[i].centroid(),
                                                   options_.line_association, centre));
      }
      sum += best;
    }
    // Laplace likelihood of the mean WAD, parameter c_m1; the prior weight carries over.
    log_weights[p] =
        std::log(std::max(weights_[p], 1e-300)) - sum / observed.size() / options_.multifilter.c_m1;
  }
  if (!normalizeLogWeights(log_weights, &weights_)) ++stats->weight_resets;
  stats->neff = effectiveSampleSize(weights_);
  if (stats->neff < options_.resample_threshold * n) {
    const std::vector<int> drawn = resampleLowVariance(weights_, n, rng_);
    std::vector<Pose2> next(n);
    for (int p = 0; p < n; ++p) next[p] = robot_[drawn[p]];
    robot_.swap(next);
    weights_.assign(n, 1.0 / n);
    stats->resampled = true;
    ++stats_.resamples;
  }
}

void MultiFilterSmc::updateMap(const std::vector<LocalFeature>& features, UpdateStats* stats) {
  if (features.empty()) return;
  const Pose2 mean = weightedPoseMean(robot_, weights_).mean;
  std::vector<GlobalFeature> global;
  for (int j = 0; j < static_cast<int>(features.size()); ++j) {
    global.push_back(inMap(features[j], mean, j));
  }
  std::vector<LandmarkType> types;
  std::vector<Eigen::Vector2d> centroids;
  for (const auto& f : filters_) {
    types.push_back(f.type());
    centroids.push_back(f.centroid());
  }
  const Eigen::Vector2d centre = wadCentre(options_.line_association, mean.head<2>());
  const WadAssociation a =
      associateByWad(global, types, centroids, options_.line_association, centre);
  // Obstacle filters matched by a feature, updated in random order (the paper's section 3.4).
  // A feature updates only the landmark it is most similar to (as the EKF does): one wall
  // near two mapped lines used to pull both, a phantom one onto it.
  std::vector<int> order;
  for (int i = 0; i < static_cast<int>(filters_.size()); ++i) {
    const int j = a.map_to_feature[i];
    if (j >= 0 && a.feature_to_map[j] == i) order.push_back(i);
  }
  stats->associated += static_cast<int>(order.size());
  if (!mapping_) return;
  std::shuffle(order.begin(), order.end(), rng_);
  for (int i : order) {
    const GlobalFeature& g = global[a.map_to_feature[i]];
    if (!filters_[i].update(g.value, centre, options_.line_association, options_.multifilter,
                            rng_)) {
      ++stats->weight_resets;
    }
    filters_[i].extendBy(g.start, g.end);
  }

  // New obstacles (Hausdorff test): one filter each, unless a feature of this same scan
  // already started a similar one.
  std::vector<GlobalFeature> added;
  for (int j : a.new_features) {
    bool duplicate = false;
    for (const auto& other : added) {
      duplicate = duplicate || (other.type == global[j].type &&
                                featureDissimilarity(other.type, other.value, global[j].value,
                                                     options_.line_association, centre) <
                                    options_.line_association.h_similar_feature);
    }
    if (duplicate) continue;
    addFilter(global[j], centre);
    added.push_back(global[j]);
    ++stats->new_landmarks;
  }
}

void MultiFilterSmc::addFilter(const GlobalFeature& feature, const Eigen::Vector2d& centre) {
  const MultiFilterOptions& m = options_.multifilter;
  const Eigen::Vector2d sigma = feature.type == LandmarkType::kLine
                                    ? Eigen::Vector2d(m.init_sigma_m, m.init_sigma_rad)
                                    : Eigen::Vector2d(m.init_sigma_m, m.init_sigma_m);
  filters_.emplace_back(next_landmark_id_++, feature.type, feature.value, sigma, m.line_particles,
                        rng_, centre);
  filters_.back().extendBy(feature.start, feature.end);
}

PoseEstimate MultiFilterSmc::estimate() const { return weightedPoseMean(robot_, weights_); }

std::vector<LandmarkEstimate> MultiFilterSmc::landmarks() const {
  std::vector<LandmarkEstimate> out;
  out.reserve(filters_.size());
  for (const auto& f : filters_) out.push_back(f.toEstimate());
  return out;
}

std::vector<WeightedPose> MultiFilterSmc::particles() const {
  std::vector<WeightedPose> out(robot_.size());
  for (size_t i = 0; i < robot_.size(); ++i) out[i] = {robot_[i], weights_[i]};
  return out;
}

FilterStats MultiFilterSmc::stats() const { return stats_; }

bool MultiFilterSmc::resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) {
  if (!pose.allFinite() || !poseCovarianceUsable(covariance)) return false;
  for (auto& p : robot_) {
    p = sampleMultivariate<3>(rng_, pose, covariance);
    p.z() = wrapAngle(p.z());
  }
  weights_.assign(robot_.size(), 1.0 / robot_.size());
  pending_motion_ = PendingMotion();
  return true;
}

bool MultiFilterSmc::loadMap(const std::vector<LandmarkEstimate>& landmarks) {
  filters_.clear();
  for (const auto& l : landmarks) {
    if (!l.mean.allFinite()) continue;
    // Drawn from the whole covariance (rho and theta are strongly correlated for a line seen
    // far from the origin) and centred on the mean saved.
    filters_.emplace_back(l.id, l.type, l.mean, Eigen::Vector2d::Zero(),
                          options_.multifilter.line_particles, rng_);
    filters_.back().redraw(l.mean, l.covariance, rng_);
    filters_.back().extendBy(l.start, l.end);
    next_landmark_id_ = std::max(next_landmark_id_, l.id + 1);
  }
  stats_.landmarks = filters_.size();
  return true;
}

bool MultiFilterSmc::setMapping(bool enabled) {
  mapping_ = enabled;
  return true;
}

}  // namespace core
}  // namespace rbpf_slam
