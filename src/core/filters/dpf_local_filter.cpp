#include "rbpf_slam/core/filters/dpf_local_filter.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/filters/observation.h"
#include "rbpf_slam/core/filters/pose_moments.h"
#include "rbpf_slam/core/plausibility.h"
#include "rbpf_slam/core/filters/resampling.h"

namespace rbpf_slam {
namespace core {
namespace {

Eigen::Matrix2d symmetric(const Eigen::Matrix2d& m) { return 0.5 * (m + m.transpose()); }

Eigen::Matrix3d regularised(const Eigen::Matrix3d& m) {
  return 0.5 * (m + m.transpose()) + Eigen::Vector3d(1e-8, 1e-8, 1e-10).asDiagonal().toDenseMatrix();
}

}  // namespace

Eigen::Matrix2d adaptiveLikelihoodCovariance(const std::vector<Eigen::Vector2d>& innovations,
                                             const std::vector<double>& weights,
                                             const Eigen::Matrix2d& measurement_noise) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  double total = 0.0;
  for (size_t j = 0; j < innovations.size(); ++j) {
    mean += weights[j] * innovations[j];
    total += weights[j];
  }
  if (!(total > 0.0)) return measurement_noise;
  mean /= total;
  Eigen::Matrix2d spread = Eigen::Matrix2d::Zero();
  for (size_t j = 0; j < innovations.size(); ++j) {
    const Eigen::Vector2d d = innovations[j] - mean;
    spread += weights[j] * d * d.transpose();
  }
  return symmetric(measurement_noise + spread / total);
}

std::vector<double> feedbackLogRatio(const std::vector<Pose2>& poses, const Pose2& target_mean,
                                     const Eigen::Matrix3d& target_cov, const Pose2& own_mean,
                                     const Eigen::Matrix3d& own_cov) {
  // With x' = x - target_mean: log ratio = -0.5 x'^T (A - B) x' - x'^T B mu' + const, where
  // A, B are the target's and own information and mu' = own_mean - target_mean.
  const Eigen::Matrix3d a = regularised(target_cov).inverse();
  const Eigen::Matrix3d b = regularised(own_cov).inverse();
  Pose2 mu = own_mean - target_mean;
  mu.z() = wrapAngle(mu.z());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(0.5 * ((a - b) + (a - b).transpose()));
  const Eigen::Vector3d linear = eigen.eigenvectors().transpose() * (-b * mu);
  std::vector<double> out(poses.size(), 0.0);
  for (size_t j = 0; j < poses.size(); ++j) {
    Pose2 d = poses[j] - target_mean;
    d.z() = wrapAngle(d.z());
    const Eigen::Vector3d y = eigen.eigenvectors().transpose() * d;
    for (int k = 0; k < 3; ++k) {
      const double lambda = eigen.eigenvalues()(k);
      if (!(lambda > 1e-9 * a.trace())) continue;  // target not sharper here: no information
      const double centre = linear(k) / lambda;
      out[j] += -0.5 * lambda * (y(k) - centre) * (y(k) - centre);
    }
  }
  return out;
}

unsigned long localFilterSeed(unsigned long seed, int index) {
  // splitmix64 of the seed mixed with the index: independent streams per local filter.
  uint64_t z = static_cast<uint64_t>(seed) + 0x9e3779b97f4a7c15ULL * (index + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return static_cast<unsigned long>(z ^ (z >> 31));
}

DpfLocalFilter::DpfLocalFilter(const FilterOptions& options, int index)
    : options_(options), index_(index), motion_model_(createMotionModel(options.motion)) {
  reset(Pose2::Zero());
}

void DpfLocalFilter::reset(const Pose2& initial_pose, const Eigen::Matrix3d* covariance) {
  rng_.seed(localFilterSeed(options_.seed, index_));
  particles_.assign(options_.particles, Particle());
  for (auto& p : particles_) {
    p.pose = covariance ? sampleMultivariate<3>(rng_, initial_pose, *covariance) : initial_pose;
    p.pose.z() = wrapAngle(p.pose.z());
  }
  weights_.assign(options_.particles, 1.0 / options_.particles);
  log_weights_.assign(options_.particles, 0.0);
  resampled_best_ = -1;
  reinitialisations_ = 0;
  has_posterior_ = false;
}

bool DpfLocalFilter::owns(int id) const {
  return id >= 0 && id % options_.dpf.local_filters == index_;
}

int DpfLocalFilter::bestParticle() const {
  return std::max(0, mostProbable(weights_, resampled_best_));
}

std::vector<DpfLocalFilter::Observation> DpfLocalFilter::prepare(const FeatureSet& features,
                                                                 int* rejected) const {
  std::vector<Observation> out;
  const MeasurementOptions& m = options_.measurement;
  for (const auto& point : features.points) {
    if (point.id >= 0 && !owns(point.id)) continue;  // another local filter's block
    // A range beyond kMaxPlausibleRangeM is corrupt data (a float32's maximum from a broken
    // driver): such a landmark stayed finite, was mapped, and pulled the fused pose to 1e35 m.
    if (point.id < 0 || !usablePoint(point) || !(point.range <= kMaxPlausibleRangeM)) {
      // Unknown identities: every local filter counts them (blocks need known ids).
      ++*rejected;
      continue;
    }
    Observation o;
    o.id = point.id;
    o.z << point.range, wrapAngle(point.bearing);
    o.noise = observationNoise(point.covariance, m.sigma_range_m, m.sigma_bearing_rad, m);
    out.push_back(o);
  }
  return out;
}

void DpfLocalFilter::applyFeedback(const DpfFeedback& feedback) {
  feedback_neff_ = static_cast<double>(particles_.size());
  if (feedback.step <= 0) return;
  for (int i : feedback.reinitialise) {
    if (i == index_) {
      reinitialise(feedback);
      return;
    }
  }
  if (!options_.dpf.feedback) return;
  if (options_.dpf.feedback_mode == "reweight" && has_posterior_) {
    reweight(feedback);
  } else {
    momentMatch(feedback);
  }
}

void DpfLocalFilter::reweight(const DpfFeedback& feedback) {
  std::vector<Pose2> poses;
  for (const auto& p : particles_) poses.push_back(p.pose);
  const std::vector<double> ratio =
      feedbackLogRatio(poses, feedback.mean, feedback.covariance, posterior_mean_, posterior_cov_);
  const size_t n = particles_.size();
  std::vector<double> log_weights = log_weights_, weights;
  for (size_t j = 0; j < n; ++j) log_weights[j] += ratio[j];
  normalizeLogWeights(log_weights, &weights);
  feedback_neff_ = effectiveSampleSize(weights);
  if (feedback_neff_ < std::max(1.5, options_.dpf.fault_neff_ratio * n)) {
    // The cloud does not cover the master's estimate (e.g. a disturbed process): reweighting
    // would leave one particle; move the cloud onto the master instead.
    momentMatch(feedback);
    return;
  }
  log_weights_ = log_weights;
  weights_ = weights;
  for (size_t j = 0; j < n; ++j) log_weights_[j] = std::log(std::max(weights_[j], 1e-300));
  resampleIfBelow(effectiveSampleSize(weights_));
}

void DpfLocalFilter::momentMatch(const DpfFeedback& feedback) {
  // The cloud gets the master's mean and covariance: p' = m + A (p - mean), A A^T scaling the
  // cloud's covariance onto the master's (Cholesky factors); particles keep their maps.
  std::vector<Pose2> poses;
  for (const auto& p : particles_) poses.push_back(p.pose);
  const PoseEstimate moments = poseMoments(poses, weights_);
  const Pose2& mean = moments.mean;
  const Eigen::Matrix3d& covariance = moments.covariance;
  const Eigen::Matrix3d target =
      regularised(options_.dpf.feedback_inflation * feedback.covariance);
  const Eigen::Matrix3d own = regularised(covariance);
  const Eigen::Matrix3d l_target = target.llt().matrixL();
  const Eigen::Matrix3d l_own = own.llt().matrixL();
  Eigen::Matrix3d a = l_target * l_own.inverse();
  if (!a.allFinite()) a.setIdentity();
  for (auto& p : particles_) {
    Pose2 d = p.pose - mean;
    d.z() = wrapAngle(d.z());
    p.pose = feedback.mean + a * d;
    p.pose.z() = wrapAngle(p.pose.z());
  }
}

void DpfLocalFilter::reinitialise(const DpfFeedback& feedback) {
  // Poses redrawn around the master's estimate; every particle keeps the best map.
  const std::shared_ptr<const Map> map = particles_[bestParticle()].map;
  Eigen::Matrix3d covariance = 0.5 * (feedback.covariance + feedback.covariance.transpose());
  covariance += Eigen::Vector3d(1e-6, 1e-6, 1e-8).asDiagonal();
  for (auto& p : particles_) {
    p.pose = sampleMultivariate<3>(rng_, feedback.mean, covariance);
    p.pose.z() = wrapAngle(p.pose.z());
    p.map = map;
  }
  weights_.assign(particles_.size(), 1.0 / particles_.size());
  log_weights_.assign(particles_.size(), 0.0);
  resampled_best_ = -1;
  has_posterior_ = false;  // the cloud is the master's now
  ++reinitialisations_;
}

DpfLocalEstimate DpfLocalFilter::step(const DpfStepInput& input, const Pose2& injected) {
  applyFeedback(input.feedback);
  MotionInput motion = input.motion;
  motion.delta += injected;
  motion.delta.z() = wrapAngle(motion.delta.z());
  DpfLocalEstimate estimate;
  const std::vector<Observation> observations = prepare(input.features, &estimate.rejected);
  const size_t n = particles_.size(), m = observations.size();

  // Innovations at each particle's predicted mean and their model covariance (eq. 12's
  // constant): measurement noise plus the linearised pose and landmark uncertainty.
  std::vector<std::vector<Eigen::Vector2d>> v(m, std::vector<Eigen::Vector2d>(n));
  std::vector<std::vector<Eigen::Matrix2d>> model_cov(m, std::vector<Eigen::Matrix2d>(n));
  std::vector<bool> known(m, true);
  for (size_t o = 0; o < m; ++o) {
    for (const auto& p : particles_) known[o] = known[o] && p.map->count(observations[o].id);
  }
  prior_means_.assign(n, Pose2::Zero());
  prior_covs_.assign(n, Eigen::Matrix3d::Zero());
  proposal_means_.assign(n, Pose2::Zero());
  proposal_covs_.assign(n, Eigen::Matrix3d::Zero());
  for (size_t j = 0; j < n; ++j) {
    Particle& p = particles_[j];
    if (m == 0) {
      p.pose = motion_model_->sample(p.pose, motion, rng_);
      proposal_means_[j] = prior_means_[j] = p.pose;
      continue;
    }
    const Pose2 mu = motion_model_->mean(p.pose, motion);
    const Eigen::Matrix3d sigma = motion_model_->covariance(p.pose, motion) +
                                  Eigen::Vector3d(1e-10, 1e-10, 1e-12).asDiagonal().toDenseMatrix();
    prior_means_[j] = mu;
    prior_covs_[j] = sigma;
    // FastSLAM 2.0 proposal: the motion prior refined by every known landmark, at mu.
    Eigen::Matrix3d information = sigma.inverse();
    Eigen::Vector3d correction = Eigen::Vector3d::Zero();
    for (size_t o = 0; o < m; ++o) {
      auto it = p.map->find(observations[o].id);
      if (it == p.map->end()) continue;
      const Prediction pred = predictPoint(mu, it->second.mean);
      const Eigen::Matrix2d q = symmetric(
          landmarkInnovationCovariance(pred, it->second.covariance, observations[o].noise));
      const Eigen::Matrix2d q_inv = q.inverse();
      v[o][j] = innovation(observations[o].z, pred.z);
      model_cov[o][j] = symmetric(q + pred.h_pose * sigma * pred.h_pose.transpose());
      information += pred.h_pose.transpose() * q_inv * pred.h_pose;
      correction += pred.h_pose.transpose() * q_inv * v[o][j];
    }
    Eigen::Matrix3d proposal_cov = information.inverse();
    Pose2 proposal_mean = mu + proposal_cov * correction;
    if (!proposal_mean.allFinite() || !proposal_cov.allFinite()) {
      // A landmark or sighting far outside what the numbers hold (a range of 1e160 is finite
      // but overflows the landmark's covariance): the motion prior alone, as FastSLAM 2.0.
      proposal_mean = mu;
      proposal_cov = sigma;
    }
    proposal_mean.z() = wrapAngle(proposal_mean.z());
    proposal_means_[j] = proposal_mean;
    proposal_covs_[j] = 0.5 * (proposal_cov + proposal_cov.transpose());
    p.pose = sampleMultivariate<3>(rng_, proposal_mean, proposal_covs_[j]);
    p.pose.z() = wrapAngle(p.pose.z());
    // Landmark EKFs at the sampled pose; unseen ids start new landmarks.
    auto map = std::make_shared<Map>(*p.map);
    for (const auto& obs : observations) {
      auto it = map->find(obs.id);
      if (it == map->end()) {
        Eigen::Matrix2d jacobian;
        Landmark lm;
        lm.mean = pointFromObservation(p.pose, obs.z, &jacobian);
        lm.covariance = symmetric(jacobian * obs.noise * jacobian.transpose());
        lm.observations = 1;
        // Not mapped when the numbers overflow (as FastSlam2's landmark update): a NaN in one
        // particle's map made its weight, then the local's estimate, NaN.
        if (lm.mean.allFinite() && lm.covariance.allFinite()) (*map)[obs.id] = lm;
        continue;
      }
      Landmark& lm = it->second;
      const Prediction pred = predictPoint(p.pose, lm.mean);
      const Eigen::Matrix2d s =
          symmetric(landmarkInnovationCovariance(pred, lm.covariance, obs.noise));
      const Eigen::Matrix2d gain = lm.covariance * pred.h_landmark.transpose() * s.inverse();
      const Eigen::Vector2d mean = lm.mean + gain * innovation(obs.z, pred.z);
      const Eigen::Matrix2d covariance =
          symmetric((Eigen::Matrix2d::Identity() - gain * pred.h_landmark) * lm.covariance);
      if (!mean.allFinite() || !covariance.allFinite()) continue;  // kept as it was
      lm.mean = mean;
      lm.covariance = covariance;
      ++lm.observations;
    }
    p.map = map;
  }
  for (size_t o = 0; o < m; ++o) estimate.new_landmarks += known[o] ? 0 : 1;
  return finishStep(input.step, v, model_cov, known, &estimate);
}

DpfLocalEstimate DpfLocalFilter::finishStep(
    long step, const std::vector<std::vector<Eigen::Vector2d>>& innovations,
    const std::vector<std::vector<Eigen::Matrix2d>>& model_cov, const std::vector<bool>& known,
    DpfLocalEstimate* estimate) {
  const size_t n = particles_.size(), m = innovations.size();
  const PoseEstimate prior = mixtureMoments(prior_means_, prior_covs_, weights_);
  estimate->prior_mean = prior.mean;
  estimate->prior_covariance = prior.covariance;
  // eq. 12 with the constant (model) covariance: the basic weights of this step.
  std::vector<double> basic_log(n, 0.0), basic;
  for (size_t o = 0; o < m; ++o) {
    if (!known[o]) continue;
    for (size_t j = 0; j < n; ++j) {
      const Eigen::Matrix2d& c = model_cov[o][j];
      basic_log[j] += -0.5 * (innovations[o][j].dot(c.ldlt().solve(innovations[o][j])) +
                              std::log(std::max(c.determinant(), 1e-300)));
    }
  }
  normalizeLogWeights(basic_log, &basic);
  std::vector<double> step_log = basic_log;
  for (size_t o = 0; o < m; ++o) {
    if (!known[o]) continue;
    // The master's innovation measure: NIS of the weighted mean innovation.
    Eigen::Vector2d mean_v = Eigen::Vector2d::Zero();
    Eigen::Matrix2d mean_c = Eigen::Matrix2d::Zero();
    for (size_t j = 0; j < n; ++j) {
      mean_v += basic[j] * innovations[o][j];
      mean_c += basic[j] * model_cov[o][j];
    }
    // The predictive covariance of the particle mixture: model covariance plus spread.
    mean_c += adaptiveLikelihoodCovariance(innovations[o], basic, Eigen::Matrix2d::Zero());
    estimate->nis_sum += mean_v.dot(mean_c.ldlt().solve(mean_v));
    ++estimate->innovations;
  }
  if (options_.dpf.adaptive_covariance && m > 0) {
    // eq. 13: recompute the likelihood covariance from the particles' spread, then eq. 12.
    std::fill(step_log.begin(), step_log.end(), 0.0);
    for (size_t o = 0; o < m; ++o) {
      if (!known[o]) continue;
      const Eigen::Matrix2d spread =
          adaptiveLikelihoodCovariance(innovations[o], basic, Eigen::Matrix2d::Zero());
      for (size_t j = 0; j < n; ++j) {
        const Eigen::Matrix2d c = model_cov[o][j] + spread;
        step_log[j] += -0.5 * (innovations[o][j].dot(c.ldlt().solve(innovations[o][j])) +
                               std::log(std::max(c.determinant(), 1e-300)));
      }
    }
  }
  for (size_t j = 0; j < n; ++j) log_weights_[j] += step_log[j];
  normalizeLogWeights(log_weights_, &weights_);
  // A cloud that did not cover the master's estimate reports that Neff (the master's Neff
  // check then sees the inconsistency even though the cloud was moved onto the master).
  estimate->neff = std::min(effectiveSampleSize(weights_), feedback_neff_);
  const PoseEstimate posterior = mixtureMoments(proposal_means_, proposal_covs_, weights_);
  const Pose2& posterior_mean = posterior.mean;
  const Eigen::Matrix3d& posterior_cov = posterior.covariance;
  estimate->particles = static_cast<int>(n);
  for (size_t j = 0; j < n; ++j) log_weights_[j] = std::log(std::max(weights_[j], 1e-300));
  resampleIfBelow(estimate->neff);
  estimate->index = index_;
  estimate->step = step;
  estimate->mean = posterior_mean;
  estimate->covariance = posterior_cov;
  has_posterior_ = true;
  posterior_mean_ = posterior_mean;
  posterior_cov_ = posterior_cov;
  estimate->landmarks = static_cast<int>(particles_[bestParticle()].map->size());
  return *estimate;
}

void DpfLocalFilter::resampleIfBelow(double neff) {
  const size_t n = particles_.size();
  if (!(neff < options_.resample_threshold * n)) return;
  const std::vector<int> drawn = resampleLowVariance(weights_, static_cast<int>(n), rng_);
  resampled_best_ = keptMostProbable(drawn, weights_);
  std::vector<Particle> next;
  next.reserve(n);
  for (int k : drawn) next.push_back(particles_[k]);
  particles_ = std::move(next);
  weights_.assign(n, 1.0 / n);
  log_weights_.assign(n, 0.0);
}

DpfLocalStream::Outcome DpfLocalStream::step(const DpfStepInput& input, const Pose2& initial_pose,
                                             const Pose2& injected, DpfLocalEstimate* estimate) {
  if (!started_ || input.run != run_ || input.step == 1) {
    // A new run (the master started or reset): the last run's particles and maps go.
    filter_.reset(initial_pose);
    run_ = input.run;
    expected_ = 1;
    started_ = true;
  }
  if (input.step < expected_) return Outcome::kRepeated;
  Outcome outcome = Outcome::kStepped;
  DpfStepInput in = input;
  if (input.step > expected_) {
    // What it missed is in the master's estimate of the step before, which is this step's
    // feedback: the cloud is redrawn from it.
    if (in.feedback.step <= 0) return Outcome::kNoFeedback;
    if (std::find(in.feedback.reinitialise.begin(), in.feedback.reinitialise.end(),
                  filter_.index()) == in.feedback.reinitialise.end()) {
      in.feedback.reinitialise.push_back(filter_.index());
    }
    outcome = Outcome::kResynchronised;
  }
  *estimate = filter_.step(in, injected);
  expected_ = input.step + 1;
  return outcome;
}

}  // namespace core
}  // namespace rbpf_slam
