#include "rbpf_slam/core/filters/robust_fastslam2.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <utility>

#include "rbpf_slam/core/filters/intermediate_path.h"
#include "rbpf_slam/core/filters/resampling.h"
#include "rbpf_slam/core/tracking/tracker_frontend.h"

namespace rbpf_slam {
namespace core {
namespace {

/// A landmark mapped no later than the oldest ancestor set's step (or loaded with a prior
/// map): one every set's particles can hold, so its observations weigh candidates of
/// different sets fairly. Decided by creation step, not id: with known ids (landmark sensors
/// that identify their beacons) the ids say nothing about when a landmark was first mapped.
bool knownToEverySet(const Landmark& landmark, int oldest_set_step) {
  return landmark.created_step <= oldest_set_step;
}

constexpr double kLog2Pi = 1.8378770664093453;

}  // namespace

RobustFastSlam2::RobustFastSlam2(const FilterOptions& options)
    : FastSlam2(options),
      tracker_(options.tracker),
      memory_(options.robust.ancestor_sets - 1, options.robust.ancestor_spacing_steps,
              options.robust.window_steps) {}

void RobustFastSlam2::reset(const Pose2& initial_pose) {
  FastSlam2::reset(initial_pose);
  forgetHistory();
  robust_stats_ = RobustStats();
}

void RobustFastSlam2::forgetHistory() {
  tracker_.reset();
  memory_.clear();
  origins_.clear();
  last_robust_step_ = -1000000;
}

bool RobustFastSlam2::resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) {
  if (!FastSlam2::resetPose(pose, covariance)) return false;
  forgetHistory();
  return true;
}

bool RobustFastSlam2::loadMap(const std::vector<LandmarkEstimate>& landmarks) {
  if (!FastSlam2::loadMap(landmarks)) return false;
  forgetHistory();
  return true;
}

Eigen::Matrix3d RobustFastSlam2::incrementCovariance(const MotionInput& motion) const {
  return motion_model_->covariance(Pose2::Zero(), motion);  // previous pose = its own frame
}

UpdateStats RobustFastSlam2::update(const FeatureSet& features) {
  const MotionInput motion = pending_motion_.has_motion ? pending_motion_.motion : MotionInput();
  int rejected = 0;
  std::vector<Observation> observations = prepare(features, &rejected);
  const int step = step_ + 1;
  const TrackerEvent event =
      tracker_.update(step, motion.delta, incrementCovariance(motion), toTrackerObservations(observations));
  StepRecord record;
  record.step = step;
  record.motion = motion;
  record.observations = observations;
  memory_.record(std::move(record));
  if (!event.new_landmark) {
    const UpdateStats stats = FastSlam2::update(features);
    memory_.setLatestDriftTurn(last_drift_turn_);
    return stats;
  }
  ++robust_stats_.tracker_events;

  // S_{t-1}, the latest set, is the first ancestor; the stored ones follow, newest first.
  AncestorSet latest;
  latest.step = step - 1;
  latest.particles = particles_;
  latest.weights = weights_;
  std::vector<const AncestorSet*> ancestors{&latest};
  for (const AncestorSet* set : memory_.usable(step)) {
    if (static_cast<int>(ancestors.size()) < options_.robust.ancestor_sets)
      ancestors.push_back(set);
  }
  UpdateStats stats;
  const bool eligible =
      ancestors.size() > 1 && step - last_robust_step_ >= options_.robust.ancestor_spacing_steps;
  // Too few observations of landmarks every set knows: z_t cannot tell a candidate propagated
  // over the skipped steps from one of S_{t-1}, so the robust step would keep older candidates
  // by their spread alone, dropping what the skipped observations taught. A plain step instead.
  const int needed = options_.robust.min_old_observations;
  const bool informed =
      eligible && (needed == 0 || oldLandmarkObservations(observations, ancestors, step) >= needed);
  if (eligible && !informed) ++robust_stats_.fallbacks;
  if (informed) {
    stats = robustUpdate(observations, ancestors, motion);
    stats.features_rejected = rejected;
    stats.features_in = static_cast<int>(features.lines.size() + features.points.size());
    last_robust_step_ = step;
  } else {
    stats = FastSlam2::update(features);
    memory_.setLatestDriftTurn(last_drift_turn_);
  }
  // Also S_0, in which nothing is mapped yet: it keeps robust steps off while it is in the
  // window (no landmark is known to every set). Leaving it out was worse (docs/results.md,
  // session 39).
  if (memory_.canStore(latest.step)) memory_.store(std::move(latest));
  return stats;
}

UpdateStats RobustFastSlam2::robustUpdate(const std::vector<Observation>& observations,
                                          const std::vector<const AncestorSet*>& ancestors,
                                          const MotionInput& motion) {
  UpdateStats stats;
  // The heading prior as in a FastSLAM 2.0 step, at the latest set's heading: the drift turn
  // goes into this step's record, which every candidate is propagated over (the turns of the
  // skipped steps are in their records already), and the walls weigh each candidate
  // (heading_measurements then counts candidates, M x K per robust step).
  const HeadingStep heading = headingStep(observations, motion);
  memory_.setLatestDriftTurn(heading.drift_turn);
  ++step_;
  pending_motion_ = PendingMotion();
  const int t = step_;
  const int count = options_.particles;
  const int oldest_set_step = ancestors.back()->step;
  std::vector<Particle> candidates;
  std::vector<int> candidate_set;
  std::vector<Pose2> candidate_start;
  std::vector<ParticleUpdate> candidate_counts;
  candidates.reserve(count * ancestors.size());
  for (size_t k = 0; k < ancestors.size(); ++k) {
    const AncestorSet& set = *ancestors[k];
    const std::vector<const StepRecord*> records = memory_.records(set.step, t);
    for (int index : resampleLowVariance(set.weights, count, rng_)) {
      Particle candidate = set.particles[index];
      // Eq. 8: x_t ~ p(x_t | x_{t-s}, u_{t-s+1:t}), as a Gaussian propagated over the steps.
      Pose2 mean = candidate.pose;
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      propagateOverRecords(*motion_model_, records, &mean, &cov);
      candidate_start.push_back(candidate.pose);
      candidate_counts.emplace_back();
      candidate.log_weight = updateCandidate(&candidate, mean, cov, observations, heading.lines,
                                             oldest_set_step, &candidate_counts.back());
      candidates.push_back(std::move(candidate));
      candidate_set.push_back(static_cast<int>(k));
    }
  }
  // Fig. 3 (b), (c): weight all M x K by z_t, keep M.
  std::vector<double> log_weights(candidates.size()), weights;
  for (size_t i = 0; i < candidates.size(); ++i) log_weights[i] = candidates[i].log_weight;
  if (!normalizeLogWeights(log_weights, &weights)) {
    ++stats.weight_resets;
    ++stats_.weight_resets;
  }
  stats.neff = effectiveSampleSize(weights) / static_cast<double>(ancestors.size());
  const std::vector<int> kept = resampleLowVariance(weights, count, rng_);
  std::vector<Particle> next;
  next.reserve(count);
  origins_.assign(count, t - 1);
  for (int i = 0; i < count; ++i) {
    next.push_back(candidates[kept[i]]);
    next.back().log_weight = 0.0;
    const AncestorSet& set = *ancestors[candidate_set[kept[i]]];
    origins_[i] = set.step;
    if (set.step < t - 1) {
      ++robust_stats_.from_older_sets;
      // The path of the kept particle ends at the set's step: its skipped poses are the
      // intermediate path (sampled during the replay, else the estimated means), so that the
      // path has one pose per update like every FastSLAM 2.0 particle's.
      std::vector<Pose2> skipped;
      if (options_.robust.intermediate_path && mapping()) {
        skipped = replayIntermediatePath(&next.back(), candidate_start[kept[i]], set.step);
      } else {
        skipped = intermediateMeans(candidate_start[kept[i]], next.back().pose, set.step);
      }
      for (const Pose2& pose : skipped) {
        next.back().path = std::make_shared<PathNode>(pose, std::move(next.back().path));
      }
    }
    next.back().path = std::make_shared<PathNode>(next.back().pose, std::move(next.back().path));
  }
  // Report the step of the most probable kept candidate.
  resampled_best_ = keptMostProbable(kept, weights);
  const int reported = resampled_best_ >= 0 ? kept[resampled_best_] : kept[0];
  stats.associated = candidate_counts[reported].associated;
  stats.new_landmarks = candidate_counts[reported].created;
  particles_.swap(next);
  weights_.assign(count, 1.0 / count);
  stats.resampled = true;
  ++stats_.resamples;
  ++stats_.updates;
  ++stats_.robust_steps;
  stats_.last_neff = stats.neff;
  stats_.landmarks = particles_[bestParticle()].map->size();
  if (!heading_prior_.ready()) heading_prior_.learn(observations, estimate().mean.z());
  return stats;
}

double RobustFastSlam2::updateCandidate(Particle* particle, const Pose2& predicted_mean,
                                        const Eigen::Matrix3d& predicted_cov,
                                        const std::vector<Observation>& observations,
                                        const HeadingPrior::LineSelection& heading_lines,
                                        int oldest_set_step, ParticleUpdate* counts) {
  const AssociationOptions& a = options_.association;
  Pose2 mean = predicted_mean;
  Eigen::Matrix3d cov = predicted_cov;
  double log_likelihood = conditionOnWalls(heading_lines, &mean, &cov);
  std::vector<std::pair<int, int>> matched;  // (observation, landmark index)
  std::vector<int> fresh;
  const LandmarkMap& map = *particle->map;
  for (size_t k = 0; k < observations.size(); ++k) {
    const Observation& o = observations[k];
    // An observation no candidate can explain by a landmark of the oldest set counts the same
    // for all: as if observed at the new-landmark threshold.
    const double log_new = newLandmarkLogLikelihood(o);
    const Match m = associate(map, mean, cov, o);
    if (m.index < 0 || m.distance2 >= a.gate_chi2) {
      log_likelihood += log_new;
      if (m.index < 0 || m.distance2 > a.new_landmark_chi2) fresh.push_back(static_cast<int>(k));
      continue;
    }
    // FastSLAM 2.0 proposal (Montemerlo 2003, eq. 3.7) from the propagated Gaussian.
    const Eigen::Matrix<double, 2, 3>& h = m.prediction.h_pose;
    const Eigen::Matrix2d s = h * cov * h.transpose() + m.landmark_innovation_cov;
    const double det = s.determinant();
    if (!(det > 0.0) || !std::isfinite(det)) continue;
    const Eigen::Matrix2d s_inv = s.inverse();
    const Eigen::Vector2d v = innovation(o.z, m.prediction.z);
    const bool old = knownToEverySet(map[m.index], oldest_set_step);
    log_likelihood += old ? -0.5 * v.dot(s_inv * v) - 0.5 * std::log(det) - kLog2Pi : log_new;
    const Eigen::Matrix<double, 3, 2> gain = cov * h.transpose() * s_inv;
    mean += gain * v;
    mean.z() = wrapAngle(mean.z());
    cov = (Eigen::Matrix3d::Identity() - gain * h) * cov;
    cov = (0.5 * (cov + cov.transpose())).eval();  // eval(): no aliasing with the transpose
    matched.emplace_back(static_cast<int>(k), m.index);
  }
  // As a FastSLAM 2.0 step draws (proposal_sample_scale). Relocalization is not tried for the
  // candidates: those from older sets are the search over earlier poses here. (The replay of
  // the skipped steps runs FastSLAM 2.0 steps, which may relocalize: with laser_robust.yaml
  // 861 times over 72 runs on the real logs, and leaving them out moved the mean ATE by 1 mm:
  // docs/results.md, session 53.)
  if (!matched.empty()) cov *= options_.proposal_sample_scale;
  particle->pose = sampleMultivariate<3>(rng_, mean, cov);
  particle->pose.z() = wrapAngle(particle->pose.z());
  counts->associated = static_cast<int>(matched.size());
  // Localization only: the map is a fixed prior.
  if (!mapping() || (matched.empty() && fresh.empty())) return log_likelihood;
  LandmarkMap& writable = mutableMap(&particle->map);
  for (const auto& [k, index] : matched) {
    Match m;
    m.index = index;
    updateLandmark(&writable, m, particle->pose, observations[k], nullptr);
  }
  for (int k : fresh) addLandmark(&writable, particle->pose, observations[k]);
  counts->created = static_cast<int>(fresh.size());
  return log_likelihood;
}

int RobustFastSlam2::oldLandmarkObservations(const std::vector<Observation>& observations,
                                             const std::vector<const AncestorSet*>& ancestors,
                                             int step) const {
  if (observations.empty()) return 0;
  const int oldest_set_step = ancestors.back()->step;
  int most = 0;
  for (const AncestorSet* set : ancestors) {
    if (set->particles.empty()) continue;
    // The set's most probable particle, moved by the odometry mean over the skipped steps with
    // the propagated covariance (as its candidates are, eq. 8): no random draw, so a fallback
    // step is FastSLAM 2.0's step exactly.
    size_t best = 0;
    for (size_t i = 1; i < set->weights.size() && i < set->particles.size(); ++i) {
      if (set->weights[i] > set->weights[best]) best = i;
    }
    const Particle& particle = set->particles[best];
    // (The current step's drift turn is not known yet: its record is not turned here.)
    Pose2 mean = particle.pose;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    propagateOverRecords(*motion_model_, memory_.records(set->step, step), &mean, &cov);
    const LandmarkMap& map = *particle.map;
    int count = 0;
    for (const Observation& o : observations) {
      const Match m = associate(map, mean, cov, o);
      if (m.index < 0 || m.distance2 >= options_.association.gate_chi2) continue;
      if (knownToEverySet(map[m.index], oldest_set_step)) ++count;
    }
    most = std::max(most, count);
  }
  return most;
}

IntermediatePath RobustFastSlam2::intermediatePath(const Pose2& start, const Pose2& end,
                                                   int from) const {
  const std::vector<const StepRecord*> records = memory_.records(from, step_);
  if (records.size() < 2) return IntermediatePath();
  std::vector<Pose2> increments;
  std::vector<Eigen::Matrix3d> covariances;
  for (const StepRecord* r : records) {
    Pose2 increment = r->motion.delta;  // with the step's drift turn, as propagateOverRecords
    increment.z() = wrapAngle(increment.z() + r->drift_turn_rad);
    increments.push_back(increment);
    covariances.push_back(incrementCovariance(r->motion));
  }
  return estimateIntermediatePath(start, end, increments, covariances,
                                  options_.robust.path_iterations);
}

std::vector<Pose2> RobustFastSlam2::intermediateMeans(const Pose2& start, const Pose2& end,
                                                     int from) const {
  std::vector<Pose2> means = intermediatePath(start, end, from).means;
  // No usable records (cannot happen for a set within the window): hold the start pose.
  if (means.empty() && step_ - from > 1) means.assign(step_ - from - 1, start);
  return means;
}

std::vector<Pose2> RobustFastSlam2::replayIntermediatePath(Particle* particle, const Pose2& start,
                                                           int from) {
  const std::vector<const StepRecord*> records = memory_.records(from, step_);
  const IntermediatePath path = intermediatePath(start, particle->pose, from);
  if (path.means.empty()) return intermediateMeans(start, particle->pose, from);
  std::vector<Pose2> poses = path.means;
  // Sec. IV: from t - 1 back to t - s + 1, each pose sampled FastSLAM 2.0-style from its
  // Gaussian and the stored observations, which update the map (relocated objects that do not
  // match become new landmarks).
  Particle replay;
  replay.map = particle->map;
  for (int j = static_cast<int>(path.means.size()) - 1; j >= 0; --j) {
    const std::vector<Observation>& observations = records[j]->observations;
    if (observations.empty()) continue;
    // Landmarks created or seen here are stamped with the robust step (step_), not the stored
    // step: the kept particle learnt them now. Creation steps decide what is old evidence at
    // later events (oldLandmarkObservations); stamping the stored steps instead, consistent
    // with the lineages that saw them live, was measured worse (docs/results.md, session 14).
    updateParticle(&replay, path.means[j], path.covariances[j], observations);
    poses[j] = replay.pose;
    ++robust_stats_.replayed_steps;
  }
  particle->map = replay.map;
  return poses;
}

}  // namespace core
}  // namespace rbpf_slam
