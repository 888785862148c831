#include "rbpf_slam/core/filters/fastslam2.h"

#include <Eigen/Dense>
#include <algorithm>
#include <stdexcept>
#include <cmath>
#include <numeric>

#include "rbpf_slam/core/filters/landmark_existence.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/filters/pose_moments.h"
#include "rbpf_slam/core/filters/relocalization.h"
#include "rbpf_slam/core/filters/resampling.h"

namespace rbpf_slam {
namespace core {
namespace {

constexpr double kLog2Pi = 1.8378770664093453;

/// log N(v; 0, s) for a 2-vector; -inf when s is not positive definite.
double logGaussian2(const Eigen::Vector2d& v, const Eigen::Matrix2d& s, Eigen::Matrix2d* s_inv) {
  const double det = s.determinant();
  if (!(det > 0.0) || !std::isfinite(det)) return -INFINITY;
  *s_inv = s.inverse();
  return -0.5 * v.dot(*s_inv * v) - 0.5 * std::log(det) - kLog2Pi;
}

/// log N(pose; mean, cov) with the heading difference wrapped; -inf when cov is singular.
double logGaussianPose(const Pose2& pose, const Pose2& mean, const Eigen::Matrix3d& cov) {
  Eigen::Vector3d d = pose - mean;
  d.z() = wrapAngle(d.z());
  const Eigen::LLT<Eigen::Matrix3d> llt(cov);
  if (llt.info() != Eigen::Success) return -INFINITY;
  const Eigen::Vector3d w = llt.matrixL().solve(d);
  const double log_det = 2.0 * llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  return -0.5 * w.squaredNorm() - 0.5 * log_det - 1.5 * kLog2Pi;
}

Eigen::Matrix2d symmetrize(const Eigen::Matrix2d& m) { return 0.5 * (m + m.transpose()); }

/// log(sum exp(values)), computed around the largest value; -inf when none is finite.
double logSumExp(const std::vector<double>& values) {
  double top = -INFINITY;
  for (double v : values) {
    if (std::isfinite(v)) top = std::max(top, v);
  }
  if (!std::isfinite(top)) return -INFINITY;
  double sum = 0.0;
  for (double v : values) {
    if (std::isfinite(v)) sum += std::exp(v - top);
  }
  return top + std::log(sum);
}

}  // namespace

PathNode::PathNode(const Pose2& p, std::shared_ptr<PathNode> previous)
    : pose(p), parent(std::move(previous)) {
  if (!parent) return;
  depth = parent->depth + 1;
  // Skew-binary: jump twice as far as the parent's jump when its two jumps are equally long.
  const PathNode* j = parent->jump;
  jump = (parent->depth - j->depth == j->depth - j->jump->depth) ? j->jump : parent.get();
}

const PathNode* ancestorAt(const PathNode* node, std::size_t depth) {
  while (node->depth > depth) node = node->jump->depth >= depth ? node->jump : node->parent.get();
  return node;
}

PathNode::~PathNode() {
  // Free the ancestors this node alone holds one by one instead of by recursion.
  std::shared_ptr<PathNode> next = std::move(parent);
  while (next && next.use_count() == 1) next = std::move(next->parent);
}

LandmarkEstimate toEstimate(const Landmark& landmark) {
  LandmarkEstimate e;
  e.id = landmark.id;
  e.type = landmark.type;
  e.mean = landmark.mean;
  e.covariance = landmark.covariance;
  e.observations = landmark.observations;
  if (landmark.type == LandmarkType::kLine) {
    e.start = pointOnLine(landmark.mean, landmark.extent_min);
    e.end = pointOnLine(landmark.mean, landmark.extent_max);
  } else {
    e.start = e.end = landmark.mean;
  }
  return e;
}

FastSlam2::FastSlam2(const FilterOptions& options)
    : FastSlam2(options, std::make_unique<EkfRule>()) {}

FastSlam2::FastSlam2(const FilterOptions& options, std::unique_ptr<EstimatorRule> rule)
    : options_(options),
      soft_ambiguous_(options.association.ambiguous_weight == "soft"),
      motion_model_(createMotionModel(options.motion)),
      rule_(std::move(rule)),
      rng_(options.seed),
      heading_prior_(options.heading_prior) {
  reset(Pose2::Zero());
}

void FastSlam2::reset(const Pose2& initial_pose) {
  particles_.assign(options_.particles, Particle());
  for (auto& p : particles_) {
    p.pose = initial_pose;
    p.map = std::make_shared<LandmarkMap>();
  }
  weights_.assign(particles_.size(), 1.0 / particles_.size());
  resampled_best_ = -1;
  pending_motion_ = PendingMotion();
  heading_prior_.reset();
  next_landmark_id_ = 0;
  step_ = 0;
  stats_ = FilterStats();
  rule_->reset();
}

void FastSlam2::predict(const MotionInput& motion) {
  ++stats_.predictions;
  pending_motion_.add(motion);  // several odometry steps between two updates compose
}

std::vector<Observation> FastSlam2::prepare(const FeatureSet& features, int* rejected) const {
  return prepareObservations(features, options_, rejected);
}

FastSlam2::Match FastSlam2::associate(const LandmarkMap& map, const Pose2& pose,
                                      const Eigen::Matrix3d& pose_cov,
                                      const Observation& observation,
                                      std::vector<Match>* gated,
                                      const std::vector<int>* exclude) const {
  // Only the landmarks the spatial index offers: a superset of those passing the pre-gate,
  // in ascending index order, so the result is the scan's (associateByScan).
  const ObservationInMap seen = inMap(pose, observation);
  std::vector<int> candidates;
  if (observation.known_id >= 0) {
    map.idCandidates(observation.known_id, &candidates);
  } else if (observation.type == LandmarkType::kLine) {
    LineQuery query;
    query.line = seen.value;
    query.start = seen.start;
    query.end = seen.end;
    query.max_angle_rad = kLinePregateAngleRad;
    query.max_rho_m = kLinePregateRhoM;
    query.overlap_margin_m = options_.association.line_overlap_margin_m;
    map.lineCandidates(query, &candidates);
  } else {
    map.pointCandidates(seen.value, pointPregateRadius(observation), &candidates);
  }
  if (exclude && !exclude->empty()) {
    candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                    [exclude](int i) {
                                      return std::find(exclude->begin(), exclude->end(), i) !=
                                             exclude->end();
                                    }),
                     candidates.end());
  }
  return associateAmong(map, pose, pose_cov, observation, seen, &candidates, gated);
}

FastSlam2::Match FastSlam2::associateByScan(const LandmarkMap& map, const Pose2& pose,
                                            const Eigen::Matrix3d& pose_cov,
                                            const Observation& observation) const {
  return associateAmong(map, pose, pose_cov, observation, inMap(pose, observation), nullptr);
}

FastSlam2::ObservationInMap FastSlam2::inMap(const Pose2& pose, const Observation& observation) {
  ObservationInMap seen;
  if (observation.type == LandmarkType::kLine) {
    seen.value = lineFromObservation(pose, observation.z, nullptr);
    seen.start = transformPoint(pose, observation.start);
    seen.end = transformPoint(pose, observation.end);
  } else {
    seen.value = pointFromObservation(pose, observation.z, nullptr);
  }
  return seen;
}

FastSlam2::Match FastSlam2::associateAmong(const LandmarkMap& map, const Pose2& pose,
                                           const Eigen::Matrix3d& pose_cov,
                                           const Observation& observation,
                                           const ObservationInMap& seen,
                                           const std::vector<int>* candidates,
                                           std::vector<Match>* gated) const {
  Match best;
  if (gated) gated->clear();
  const bool is_line = observation.type == LandmarkType::kLine;
  // The observation in the map frame at the current pose estimate, for a cheap pre-gate.
  const Eigen::Vector2d& in_map = seen.value;
  const double point_pregate = pointPregateRadius(observation);
  const Eigen::Vector2d &seg_a = seen.start, &seg_b = seen.end;
  const int count = candidates ? static_cast<int>(candidates->size()) : map.size();
  for (int c = 0; c < count; ++c) {
    const int i = candidates ? (*candidates)[c] : c;
    const Landmark& lm = map[i];
    if (lm.type != observation.type) continue;
    if (observation.known_id >= 0) {
      if (lm.id != observation.known_id) continue;
    } else if (is_line) {
      const Eigen::Vector2d d = lineDifference(in_map, lm.mean);
      if (std::fabs(d.y()) > kLinePregateAngleRad || std::fabs(d.x()) > kLinePregateRhoM) continue;
      // Collinear walls of different rooms share (rho, alpha): require the segments to meet.
      const double a = alongLine(lm.mean, seg_a), b = alongLine(lm.mean, seg_b);
      const double gap = std::max({std::min(a, b) - lm.extent_max, lm.extent_min - std::max(a, b), 0.0});
      if (gap > options_.association.line_overlap_margin_m) continue;
    } else if ((in_map - lm.mean).norm() > point_pregate) {
      continue;
    }
    const Prediction p = is_line ? predictLine(pose, lm.mean, observation.z.y())
                                 : predictPoint(pose, lm.mean);
    const Eigen::Matrix2d z_cov = landmarkInnovationCovariance(p, lm.covariance, observation.noise);
    // R as given, also for H-infinity's adaptive attenuation: gating at R x (1 - theta) would
    // feed back (a tighter gate keeps only close matches, whose smaller innovations raise theta).
    const Eigen::Matrix2d s = z_cov + p.h_pose * pose_cov * p.h_pose.transpose();
    const Eigen::Vector2d v = innovation(observation.z, p.z);
    const double d2 = v.dot(s.inverse() * v);
    if (!std::isfinite(d2)) continue;
    if (gated && d2 < options_.association.gate_chi2) {
      gated->push_back(Match{i, d2, p, z_cov});
    }
    if (d2 < best.distance2) {
      best.distance2 = d2;
      best.index = i;
      best.prediction = p;
      best.landmark_innovation_cov = z_cov;
    }
  }
  if (observation.known_id >= 0 && best.index >= 0) best.distance2 = 0.0;  // identity known
  return best;
}

void FastSlam2::addLandmark(LandmarkMap* map, const Pose2& pose, const Observation& observation) {
  Landmark lm;
  lm.id = observation.known_id >= 0 ? observation.known_id : next_landmark_id_++;
  lm.identified = observation.known_id >= 0;
  lm.type = observation.type;
  Eigen::Matrix2d g;
  if (observation.type == LandmarkType::kLine) {
    lm.mean = lineFromObservation(pose, observation.z, &g);
    const double a = alongLine(lm.mean, transformPoint(pose, observation.start));
    const double b = alongLine(lm.mean, transformPoint(pose, observation.end));
    lm.extent_min = std::min(a, b);
    lm.extent_max = std::max(a, b);
  } else {
    lm.mean = pointFromObservation(pose, observation.z, &g);
  }
  lm.covariance = symmetrize(g * observation.noise * g.transpose());  // Havangi eq. 35
  lm.last_seen_step = step_;
  lm.created_step = step_;
  map->add(lm);
}

bool FastSlam2::updateLandmark(LandmarkMap* map, const Match& match, const Pose2& pose,
                               const Observation& observation, double* log_likelihood) {
  Landmark lm = (*map)[match.index];
  const bool is_line = lm.type == LandmarkType::kLine;
  const Prediction p = is_line ? predictLine(pose, lm.mean, observation.z.y())
                               : predictPoint(pose, lm.mean);
  const Eigen::Matrix2d s = landmarkInnovationCovariance(p, lm.covariance, observation.noise);
  Eigen::Matrix2d s_inv;
  const Eigen::Vector2d v = innovation(observation.z, p.z);
  const double ll = logGaussian2(v, s, &s_inv);
  if (!std::isfinite(ll)) return true;
  // EKF (Montemerlo 2003) or H-infinity (Havangi eqs. 28-34) landmark update; for points
  // optionally iterated: relinearised at the updated mean, x = x0 + K (z - h(x) - H (x0 - x)).
  Correction<2> c = rule_->correctLandmark(lm.covariance, p.h_landmark, observation.noise);
  if (!c.ok) return true;
  Eigen::Vector2d mean = lm.mean + c.gain * v;
  bool fell_back = c.fallback;  // any iteration's H-infinity step fell back to the EKF
  for (int i = 1; i < options_.measurement.landmark_iterations && !is_line; ++i) {
    const Prediction pi = predictPoint(pose, mean);
    const Correction<2> ci = rule_->correctLandmark(lm.covariance, pi.h_landmark, observation.noise);
    if (!ci.ok || !pi.z.allFinite()) break;
    const Eigen::Vector2d vi = innovation(observation.z, pi.z) - pi.h_landmark * (lm.mean - mean);
    mean = lm.mean + ci.gain * vi;
    c = ci;
    fell_back = fell_back || ci.fallback;
  }
  if (log_likelihood) *log_likelihood += ll;
  lm.mean = mean;
  lm.covariance = c.covariance;
  if (is_line) {
    lm.mean.y() = wrapAngle(lm.mean.y());
    if (lm.mean.x() < 0.0) {  // keep rho >= 0: flip the normal and the extent's direction
      lm.mean << -lm.mean.x(), wrapAngle(lm.mean.y() + M_PI);
      lm.covariance(0, 1) = lm.covariance(1, 0) = -lm.covariance(0, 1);
      reverseExtent(&lm.extent_min, &lm.extent_max);
    }
    const double a = alongLine(lm.mean, transformPoint(pose, observation.start));
    const double b = alongLine(lm.mean, transformPoint(pose, observation.end));
    lm.extent_min = std::min({lm.extent_min, a, b});
    lm.extent_max = std::max({lm.extent_max, a, b});
  }
  ++lm.observations;
  lm.identified = lm.identified || observation.known_id >= 0;  // e.g. a landmark of a loaded map
  lm.last_seen_step = step_;
  if (lm.mean.allFinite() && lm.covariance.allFinite()) map->set(match.index, lm);
  return !fell_back;
}

double FastSlam2::matchLogLikelihood(const Eigen::Matrix3d& pose_cov,
                                     const Observation& observation, const Match& match) const {
  // The marginal likelihood of FastSLAM 2.0's weight: the pose's and the landmark's uncertainty
  // and the measurement noise (the last two scaled by the rule's weight noise scale).
  const Eigen::Matrix<double, 2, 3>& h = match.prediction.h_pose;
  const Eigen::Matrix2d s =
      h * pose_cov * h.transpose() + rule_->weightNoiseScale() * match.landmark_innovation_cov;
  Eigen::Matrix2d s_inv;
  return logGaussian2(innovation(observation.z, match.prediction.z), s, &s_inv);
}

double FastSlam2::newLandmarkLogLikelihood(const Observation& observation) const {
  const double scale = rule_->weightNoiseScale();  // as for a match (1: FastSLAM 2.0)
  return -0.5 * options_.association.new_landmark_chi2 -
         0.5 * std::log(scale * scale * observation.noise.determinant()) - kLog2Pi;
}

std::vector<size_t> FastSlam2::associationOrder(
    const LandmarkMap& map, const Pose2& prior_mean, const Eigen::Matrix3d& prior_cov,
    const std::vector<Observation>& observations) const {
  if (!options_.association.exclusive) return {};
  std::vector<size_t> slots;  // the unidentified point features, in frame order
  for (size_t k = 0; k < observations.size(); ++k) {
    if (observations[k].type == LandmarkType::kPoint && observations[k].known_id < 0) {
      slots.push_back(k);
    }
  }
  if (slots.size() < 2) return {};
  std::vector<size_t> order(observations.size());
  std::iota(order.begin(), order.end(), 0);
  std::vector<double> best(observations.size(), 0.0);
  for (size_t k : slots) best[k] = associate(map, prior_mean, prior_cov, observations[k]).distance2;
  std::vector<size_t> sorted = slots;
  std::stable_sort(sorted.begin(), sorted.end(),
                   [&best](size_t i, size_t j) { return best[i] < best[j]; });
  for (size_t i = 0; i < slots.size(); ++i) order[slots[i]] = sorted[i];
  return order;
}

FastSlam2::Proposal FastSlam2::refineProposal(const LandmarkMap& map, const Pose2& prior_mean,
                                              const Eigen::Matrix3d& prior_cov,
                                              const std::vector<Observation>& observations,
                                              Rng* rng) const {
  Proposal q;
  q.mean = prior_mean;
  q.cov = prior_cov;
  const bool pointwise = rule_->pointwiseWeights();
  const AssociationOptions& a = options_.association;
  std::vector<Match> gated;
  std::vector<double> likelihoods;
  std::vector<int> taken;  // exclusive: point landmarks already matched by a feature of the frame
  const std::vector<size_t> order = associationOrder(map, prior_mean, prior_cov, observations);
  for (size_t n = 0; n < observations.size(); ++n) {
    const size_t k = order.empty() ? n : order[n];
    const Observation& o = observations[k];
    const bool sampling = a.sample && rng && o.known_id < 0;
    const bool is_point = o.type == LandmarkType::kPoint;
    const bool exclusive = a.exclusive && o.known_id < 0 && is_point;
    Match m = associate(map, q.mean, q.cov, o, sampling ? &gated : nullptr,
                        exclusive ? &taken : nullptr);
    if (m.index >= 0 && m.distance2 < a.gate_chi2) {
      double ll = 0.0;       // the weight's factor for this observation (log)
      double drawn_ll = 0.0;  // the likelihood of the match taken (log)
      if (sampling && gated.size() > 1) {
        // Data association sampling: draw the match by likelihood.
        likelihoods.clear();
        for (const Match& g : gated) likelihoods.push_back(matchLogLikelihood(q.cov, o, g));
        const double total = logSumExp(likelihoods);
        if (!std::isfinite(total)) continue;
        const double u = sampleUniform(*rng);
        double cumulative = 0.0;
        int pick = -1;
        for (size_t j = 0; j < gated.size(); ++j) {
          if (!std::isfinite(likelihoods[j])) continue;
          pick = static_cast<int>(j);  // the last finite one if rounding leaves u above the sum
          cumulative += std::exp(likelihoods[j] - total);
          if (u < cumulative) break;
        }
        m = gated[pick];
        drawn_ll = likelihoods[pick];
        // sum: the importance weight of the draw (the association's marginal, every landmark
        // in the gate equally likely a priori); max: the most likely match's, as without
        // sampling (a particle is not favoured for having copies of a landmark in the gate).
        ll = a.sample_weight == "max" ? *std::max_element(likelihoods.begin(), likelihoods.end())
                                      : total;
      } else {
        ll = drawn_ll = matchLogLikelihood(q.cov, o, m);
      }
      if (!std::isfinite(ll)) continue;
      // Proposal: refine the pose Gaussian with this observation (Montemerlo 2003, eq. 3.7).
      const Eigen::Matrix<double, 2, 3>& h = m.prediction.h_pose;
      const Eigen::Vector2d v = innovation(o.z, m.prediction.z);
      const Correction<3> c = ekfCorrection<3>(q.cov, h, m.landmark_innovation_cov);
      if (!c.ok) continue;
      // The marginal weight of FastSLAM 2.0; the pointwise weight adds the drawn match's
      // likelihood at the drawn pose later, so only the draw's correction goes in here.
      q.log_likelihood += pointwise ? ll - drawn_ll : ll;
      if (rule_->learnsFromInnovations()) {
        // NIS with the landmark's part (R and the landmark's covariance) scaled by 1 - theta,
        // the scale the rule is testing; the proposal's sequential covariance is the EKF's.
        const Eigen::Matrix2d s1 =
            h * q.cov * h.transpose() + (1.0 - rule_->theta()) * m.landmark_innovation_cov;
        const double nis = v.dot(s1.inverse() * v);
        if (std::isfinite(nis)) q.nis.push_back(nis);
      }
      q.mean += c.gain * v;
      q.mean.z() = wrapAngle(q.mean.z());
      q.cov = c.covariance;
      q.matched.emplace_back(static_cast<int>(k), m.index);
      if (a.exclusive && is_point) taken.push_back(m.index);  // known ids take theirs too
    } else if (m.index < 0 || m.distance2 > a.new_landmark_chi2) {
      q.log_likelihood += newLandmarkLogLikelihood(o);
      q.fresh.push_back(static_cast<int>(k));
    } else if (soft_ambiguous_) {
      // Between the gate and the new-landmark threshold: neither matched nor mapped. "soft"
      // weighs it as its nearest landmark or a new one (the sum of the two likelihoods), close
      // to a match's weight at the gate and a new landmark's at the threshold; "none" leaves
      // it out (a factor of 1), which favours a particle that leaves its features ambiguous
      // over one that sees them as new (docs/results.md, session 33).
      const double log_match = matchLogLikelihood(q.cov, o, m);
      const double log_new = newLandmarkLogLikelihood(o);
      q.log_likelihood += std::isfinite(log_match) ? logSumExp({log_match, log_new}) : log_new;
    }
  }
  return q;
}

bool FastSlam2::relocalize(const LandmarkMap& map, const Eigen::Matrix3d& motion_cov,
                           const std::vector<Observation>& observations, Pose2* prior_mean,
                           Proposal* proposal) const {
  const RelocalizationOptions& r = options_.relocalization;
  if (!r.enabled) return false;
  const int unmatched = static_cast<int>(observations.size() - proposal->matched.size());
  if (unmatched < r.min_unmatched || unmatched < r.min_unmatched_ratio * observations.size()) {
    return false;
  }
  const PoseCorrection c =
      searchPoseCorrection(map, *prior_mean, observations, r,
                           options_.association.line_overlap_margin_m,
                           r.min_landmark_age > 0 ? step_ - r.min_landmark_age : 2147483647);
  if (!c.found) return false;
  Proposal moved = refineProposal(map, c.pose, motion_cov, observations);
  const int needed = std::max<int>(r.min_matches, proposal->matched.size() + r.min_gain);
  if (static_cast<int>(moved.matched.size()) < needed ||
      moved.matched.size() < r.min_matched_ratio * observations.size()) {
    return false;
  }
  *prior_mean = c.pose;
  *proposal = std::move(moved);
  return true;
}

FastSlam2::ParticleUpdate FastSlam2::updateParticle(Particle* particle,
                                                    const Pose2& predicted,
                                                    const Eigen::Matrix3d& motion_cov,
                                                    const std::vector<Observation>& observations) {
  ParticleUpdate result;
  const bool pointwise = rule_->pointwiseWeights();
  const LandmarkMap& map = *particle->map;
  Pose2 predicted_mean = predicted;
  Proposal q = refineProposal(map, predicted_mean, motion_cov, observations, &rng_);
  result.relocalized = relocalize(map, motion_cov, observations, &predicted_mean, &q);
  Pose2& mean = q.mean;
  Eigen::Matrix3d& cov = q.cov;
  double& log_likelihood = q.log_likelihood;
  const std::vector<std::pair<int, int>>& matched = q.matched;
  const std::vector<int>& fresh = q.fresh;
  result.nis = std::move(q.nis);
  if (rule_->attenuatesPose() && !matched.empty()) {
    // H-infinity proposal (Havangi eqs. 20-23, every matched landmark of the step stacked, the
    // landmark's uncertainty counted in R as in FastSLAM 2.0).
    const Attenuation<3> h = rule_->attenuatePose(motion_cov, cov);
    if (h.correction_scale != Eigen::Matrix3d::Identity()) {
      Eigen::Vector3d shift = mean - predicted_mean;
      shift.z() = wrapAngle(shift.z());
      mean = predicted_mean + h.correction_scale * shift;
      mean.z() = wrapAngle(mean.z());
    }
    cov = h.covariance;
    result.fallbacks += h.fallback;
  }
  // Draw from the proposal (Havangi eq. 24); proposal_sample_scale < 1 narrows the draw when
  // observations refined it (1: FastSLAM 2.0 exactly; see FilterOptions).
  if (!matched.empty()) cov *= options_.proposal_sample_scale;
  particle->pose = sampleMultivariate<3>(rng_, mean, cov);
  particle->pose.z() = wrapAngle(particle->pose.z());
  // Pointwise importance weight (Havangi eq. 36): p(z | s) p(s | s_prev, u) / q(s) at the
  // drawn pose s; p(z | s) is accumulated by the landmark updates below.
  if (pointwise && !matched.empty()) {
    log_likelihood += logGaussianPose(particle->pose, predicted_mean, motion_cov) -
                      logGaussianPose(particle->pose, mean, cov);
  }
  particle->log_weight += log_likelihood;
  if (!mapping_) {  // localization only: the map is a fixed prior
    result.associated = static_cast<int>(matched.size());
    if (pointwise) {  // p(z | s) of eq. 36 without updating the landmarks
      for (const auto& [k, index] : matched) {
        const Landmark& lm = map[index];
        const Prediction p = lm.type == LandmarkType::kLine
                                 ? predictLine(particle->pose, lm.mean, observations[k].z.y())
                                 : predictPoint(particle->pose, lm.mean);
        Eigen::Matrix2d s_inv;
        const double ll = logGaussian2(
            innovation(observations[k].z, p.z),
            landmarkInnovationCovariance(p, lm.covariance, observations[k].noise),
            &s_inv);
        if (std::isfinite(ll)) particle->log_weight += ll;
      }
    }
    return result;
  }
  if (matched.empty() && fresh.empty()) return result;
  LandmarkMap& writable = mutableMap(&particle->map);
  for (const auto& [k, index] : matched) {
    Match m;
    m.index = index;
    if (!updateLandmark(&writable, m, particle->pose, observations[k],
                        pointwise ? &particle->log_weight : nullptr)) {
      ++result.fallbacks;
    }
    ++result.associated;
  }
  for (int k : fresh) {
    addLandmark(&writable, particle->pose, observations[k]);
    ++result.created;
  }
  return result;
}

FastSlam2::HeadingStep FastSlam2::headingStep(const std::vector<Observation>& observations,
                                              const MotionInput& motion) {
  HeadingStep step;
  // The heading prior picks its lines at the filter's predicted heading, the same for every
  // particle, so that all are weighed on the same lines.
  double reference_heading = 0.0;
  if (heading_prior_.ready()) {
    std::vector<Pose2> poses;
    poses.reserve(particles_.size());
    for (const Particle& p : particles_) poses.push_back(p.pose);
    reference_heading = wrapAngle(poseMoments(poses, weights_).mean.z() + motion.delta.z());
  }
  // Drift tracking: one correction of the mean heading, the same for every particle.
  if (heading_prior_.tracksDrift()) {
    const double scale = motion.noise_scale * motion.noise_scale;
    heading_prior_.predictDrift(motion.delta.z() * scale, motion.delta.head<2>().norm() * scale);
    step.drift_turn = heading_prior_.correctDrift(observations, reference_heading);
    reference_heading = wrapAngle(reference_heading + step.drift_turn);
  }
  step.lines = heading_prior_.select(observations, reference_heading);
  last_drift_turn_ = step.drift_turn;
  return step;
}

double FastSlam2::conditionOnWalls(const HeadingPrior::LineSelection& lines, Pose2* mean,
                                   Eigen::Matrix3d* cov) {
  double axis_offset = 0.0;
  if (!heading_prior_.residual(lines, mean->z(), &axis_offset)) return 0.0;
  ++stats_.heading_measurements;
  return heading_prior_.condition(axis_offset, mean, cov);
}

UpdateStats FastSlam2::update(const FeatureSet& features) {
  UpdateStats stats;
  ++step_;
  const std::vector<Observation> observations = prepare(features, &stats.features_rejected);
  stats.features_in = static_cast<int>(features.lines.size() + features.points.size());
  const MotionInput motion = pending_motion_.take();
  std::vector<ParticleUpdate> results(particles_.size());
  const HeadingStep heading = headingStep(observations, motion);
  const double drift_turn = heading.drift_turn;
  const HeadingPrior::LineSelection& heading_lines = heading.lines;
  std::vector<double> log_weights(particles_.size());
  for (size_t i = 0; i < particles_.size(); ++i) log_weights[i] = particles_[i].log_weight;
  const double log_mass_before = logSumExp(log_weights);
  for (size_t i = 0; i < particles_.size(); ++i) {
    Particle& p = particles_[i];
    if (observations.empty()) {
      p.pose = motion_model_->sample(p.pose, motion, rng_);
      continue;  // its path node is added below
    }
    Pose2 predicted = motion_model_->mean(p.pose, motion);
    predicted.z() = wrapAngle(predicted.z() + drift_turn);
    Eigen::Matrix3d motion_cov = motion_model_->covariance(p.pose, motion);
    // The prior the landmarks then refine is the motion prediction conditioned on the walls.
    p.log_weight += conditionOnWalls(heading_lines, &predicted, &motion_cov);
    results[i] = updateParticle(&p, predicted, motion_cov, observations);
    if (mapping_) results[i].removed = manageExistence(options_.existence, &p.map, p.pose, step_);
    stats.fallbacks += results[i].fallbacks;
    stats.relocalized += results[i].relocalized;
  }
  stats_.relocalizations += stats.relocalized;
  if (rule_->learnsFromInnovations()) {
    std::vector<double> nis;
    for (ParticleUpdate& r : results) nis.insert(nis.end(), r.nis.begin(), r.nis.end());
    rule_->observeInnovations(std::move(nis));
  }
  stats_.attenuation = rule_->theta();
  // log p(z_t | z_1:t-1), estimated by the weights' total mass after this step's likelihoods
  // over their mass before (the filter's marginal likelihood, summed by an ensemble).
  for (size_t i = 0; i < particles_.size(); ++i) log_weights[i] = particles_[i].log_weight;
  stats.log_evidence = logSumExp(log_weights) - log_mass_before;
  for (auto& p : particles_) p.path = std::make_shared<PathNode>(p.pose, std::move(p.path));
  stats_.fallbacks += stats.fallbacks;
  // Report the association of the most probable particle of this step, found before
  // resampling reorders the particles (results follow the order before it).
  int most_probable = -1;
  for (size_t i = 0; i < particles_.size(); ++i) {
    if (most_probable < 0 || particles_[i].log_weight > particles_[most_probable].log_weight) {
      most_probable = static_cast<int>(i);
    }
  }
  weighAndResample(&stats);
  const int best = bestParticle();
  if (!heading_prior_.ready()) heading_prior_.learn(observations, estimate().mean.z());
  if (most_probable >= 0 && most_probable < static_cast<int>(results.size())) {
    stats.associated = results[most_probable].associated;
    stats.new_landmarks = results[most_probable].created;
  }
  ++stats_.updates;
  stats_.last_neff = stats.neff;
  stats_.landmarks = best >= 0 ? particles_[best].map->size() : 0;
  return stats;
}

void FastSlam2::weighAndResample(UpdateStats* stats) {
  std::vector<double> log_weights(particles_.size());
  for (size_t i = 0; i < particles_.size(); ++i) log_weights[i] = particles_[i].log_weight;
  if (!normalizeLogWeights(log_weights, &weights_)) {
    ++stats->weight_resets;
    ++stats_.weight_resets;
  }
  stats->neff = effectiveSampleSize(weights_);
  if (stats->neff < options_.resample_threshold * particles_.size()) {
    const std::vector<int> indices =
        resampleLowVariance(weights_, static_cast<int>(particles_.size()), rng_);
    resampled_best_ = keptMostProbable(indices, weights_);
    std::vector<Particle> next;
    next.reserve(indices.size());
    for (int index : indices) next.push_back(particles_[index]);  // maps shared, not copied
    particles_.swap(next);
    for (auto& p : particles_) p.log_weight = 0.0;
    weights_.assign(particles_.size(), 1.0 / particles_.size());
    stats->resampled = true;
    ++stats_.resamples;
  } else {
    resampled_best_ = -1;
    for (size_t i = 0; i < particles_.size(); ++i) {
      particles_[i].log_weight = weights_[i] > 0.0 ? std::log(weights_[i]) : -745.0;
    }
  }
}

int FastSlam2::bestParticle() const { return mostProbable(weights_, resampled_best_); }

std::vector<Pose2> FastSlam2::bestPath() const {
  std::vector<Pose2> path;
  const int best = bestParticle();
  if (best < 0) return path;
  path.reserve(static_cast<size_t>(stats_.updates) + 1);  // one pose per update, usually
  for (const PathNode* n = particles_[best].path.get(); n != nullptr; n = n->parent.get()) {
    path.push_back(n->pose);
  }
  std::reverse(path.begin(), path.end());
  return path;
}

std::vector<Pose2> FastSlam2::bestPathSample(std::size_t max_poses, std::size_t* length) const {
  if (max_poses < 1) throw std::invalid_argument("bestPathSample needs max_poses >= 1");
  const int best = bestParticle();
  const PathNode* tip = best < 0 ? nullptr : particles_[best].path.get();
  if (length) *length = tip ? tip->depth + 1 : 0;
  if (!tip || tip->depth + 1 <= max_poses) return bestPath();
  if (max_poses == 1) return {tip->pose};
  // The indices evenlySpacedPoses picks, newest first, each found from the one after it.
  std::vector<Pose2> out(max_poses);
  const std::size_t last = tip->depth;
  const PathNode* node = tip;
  for (std::size_t i = max_poses; i-- > 0;) {
    node = ancestorAt(node, i * last / (max_poses - 1));
    out[i] = node->pose;
  }
  return out;
}

PoseEstimate FastSlam2::estimate() const {
  std::vector<Pose2> poses(particles_.size());
  for (size_t i = 0; i < particles_.size(); ++i) {
    poses[i] = pending_motion_.has_motion
                   ? compose(particles_[i].pose, pending_motion_.motion.delta)
                   : particles_[i].pose;
  }
  return poseMoments(poses, weights_);
}

std::vector<LandmarkEstimate> FastSlam2::landmarks() const {
  std::vector<LandmarkEstimate> out;
  const int best = bestParticle();
  if (best < 0) return out;
  const LandmarkMap& map = *particles_[best].map;
  out.reserve(map.size());
  for (int i = 0; i < map.size(); ++i) out.push_back(toEstimate(map[i]));
  return out;
}

std::vector<WeightedPose> FastSlam2::particles() const {
  std::vector<WeightedPose> out(particles_.size());
  for (size_t i = 0; i < particles_.size(); ++i) {
    out[i].pose = particles_[i].pose;
    out[i].weight = weights_[i];
  }
  return out;
}

FilterStats FastSlam2::stats() const { return stats_; }

bool FastSlam2::resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) {
  if (!pose.allFinite() || !poseCovarianceUsable(covariance)) return false;
  const Eigen::Matrix3d c = 0.5 * (covariance + covariance.transpose());
  for (auto& p : particles_) {
    p.pose = sampleMultivariate<3>(rng_, pose, c);
    p.pose.z() = wrapAngle(p.pose.z());
    p.log_weight = 0.0;
    p.path.reset();
  }
  weights_.assign(particles_.size(), 1.0 / particles_.size());
  resampled_best_ = -1;
  pending_motion_ = PendingMotion();
  if (!heading_prior_.ready()) heading_prior_.reset();  // lines learned at the old pose
  heading_prior_.setDriftVariance(c(2, 2));             // the given heading's uncertainty
  return true;
}

bool FastSlam2::loadMap(const std::vector<LandmarkEstimate>& landmarks) {
  auto map = std::make_shared<LandmarkMap>();
  int max_id = -1;
  for (const LandmarkEstimate& e : landmarks) {
    if (!e.mean.allFinite() || !e.covariance.allFinite()) return false;
    Landmark lm;
    lm.id = e.id;
    lm.type = e.type;
    lm.mean = e.mean;
    lm.covariance = symmetrize(e.covariance);
    lm.observations = std::max(1, e.observations);
    lm.last_seen_step = step_;
    if (lm.type == LandmarkType::kLine) {
      const double a = alongLine(lm.mean, e.start), b = alongLine(lm.mean, e.end);
      lm.extent_min = std::min(a, b);
      lm.extent_max = std::max(a, b);
    }
    map->add(lm);
    max_id = std::max(max_id, lm.id);
  }
  for (auto& p : particles_) p.map = map;  // shared until a particle writes to it
  next_landmark_id_ = std::max(next_landmark_id_, max_id + 1);
  // The heading prior's wall families are the loaded map's (its frame is the one that counts).
  heading_prior_.reset();
  std::vector<Observation> walls;
  for (const LandmarkEstimate& e : landmarks) {
    if (e.type != LandmarkType::kLine) continue;
    Observation o;
    o.type = LandmarkType::kLine;
    o.z = e.mean;
    o.start = e.start;
    o.end = e.end;
    walls.push_back(o);
  }
  heading_prior_.learn(walls, 0.0, /*conclude=*/true);
  stats_.landmarks = map->size();
  return true;
}

bool FastSlam2::setMapping(bool enabled) {
  mapping_ = enabled;
  return true;
}

}  // namespace core
}  // namespace rbpf_slam
