#include "rbpf_slam/core/filters/distributed_filter.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <thread>

#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {

void validate(const DpfOptions& o) {
  requireRange("dpf.local_filters", o.local_filters, 1, 64);
  requireRange("dpf.threads", o.threads, 0, 64);
  requireOneOf("dpf.weighting", o.weighting, {"innovation", "neff", "mixed"});
  requireOneOf("dpf.fusion", o.fusion, {"information", "average"});
  requireOneOf("dpf.feedback_mode", o.feedback_mode, {"reweight", "moment"});
  requireRange("dpf.mix_innovation", o.mix_innovation, 0.0, 1.0);
  requireRange("dpf.feedback_inflation", o.feedback_inflation, 1.0, 100.0);
  requireRange("dpf.innovation_smoothing", o.innovation_smoothing, 1e-3, 1.0);
  requireRange("dpf.fault_nis", o.fault_nis, 0.0, 1e9);
  requireRange("dpf.fault_neff_ratio", o.fault_neff_ratio, 0.0, 1.0);
  requireRange("dpf.fault_prior_chi2", o.fault_prior_chi2, 0.0, 1e9);
  requireRange("dpf.suspect_weight", o.suspect_weight, 0.0, 1.0);
  requireRange("dpf.isolate_after_steps", o.isolate_after_steps, 1, 1000000);
  requireRange("dpf.readmit_after_steps", o.readmit_after_steps, 0, 1000000);
  requireRange("dpf.step_timeout_s", o.step_timeout_s, 1e-3, 1e6);
  requireRange("fault.start_step", o.fault.start_step, 1, 1e9);
  requireRange("fault.local_index", o.fault.local_index, 0, o.local_filters - 1);
  requireRange("fault.sigma_xy_m", o.fault.sigma_xy_m, 0.0, 100.0);
  requireRange("fault.sigma_theta_rad", o.fault.sigma_theta_rad, 0.0, 10.0);
}

DpfCoordinator::DpfCoordinator(const FilterOptions& options)
    : options_(options), master_(options.dpf), injector_(options.dpf.fault, options.seed) {
  validate(options.dpf);
  reset(Pose2::Zero());
}

void DpfCoordinator::reset(const Pose2& initial_pose, const Eigen::Matrix3d& covariance) {
  master_.reset(initial_pose, covariance);
  injector_.reset();
  pending_ = PendingMotion();
  feedback_ = DpfFeedback();
  estimates_.clear();
  step_ = 0;
  stats_ = FilterStats();
}

void DpfCoordinator::predict(const MotionInput& motion) {
  pending_.add(motion);
  ++stats_.predictions;
}

DpfStepInput DpfCoordinator::beginStep(const FeatureSet& features, std::vector<Pose2>* injected) {
  DpfStepInput input;
  input.step = step_ + 1;
  input.motion = pending_.take();
  input.features = features;
  input.features.scan.reset();  // the local filters use point features only
  input.features.cones.clear();
  input.feedback = feedback_;
  injected->assign(options_.dpf.local_filters, Pose2::Zero());
  (*injected)[options_.dpf.fault.local_index] = injector_.disturbance(input.step);
  return input;
}

UpdateStats DpfCoordinator::finishStep(const DpfStepInput& input,
                                       std::vector<DpfLocalEstimate> estimates) {
  const DpfMasterOutput out = master_.fuse(input.step, input.motion, estimates);
  step_ = input.step;
  feedback_ = out.feedback;
  std::vector<int> known_landmarks(options_.dpf.local_filters, 0);
  for (const auto& e : estimates_) known_landmarks[e.index] = e.landmarks;
  estimates_.assign(options_.dpf.local_filters, DpfLocalEstimate());
  for (auto& e : estimates) {
    estimates_[e.index] = e;  // fuse() checked the indices
    // A local that did not answer keeps the map it had (RemoteDpfFilter::landmarks()).
    if (!e.answered) estimates_[e.index].landmarks = known_landmarks[e.index];
  }

  UpdateStats stats;
  const FeatureSet& features = input.features;
  stats.features_in = static_cast<int>(features.points.size() + features.lines.size());
  stats.features_rejected = static_cast<int>(features.lines.size());  // lines are not used
  double neff = 0.0;
  int rejected = 0;
  for (size_t i = 0; i < estimates_.size(); ++i) {
    const DpfLocalEstimate& e = estimates_[i];
    neff += out.weights[i] * e.neff;
    stats.associated += e.innovations;
    stats.new_landmarks += e.new_landmarks;
    rejected = std::max(rejected, e.rejected);  // every local counts unknown ids
  }
  stats.features_rejected += rejected;
  stats.neff = neff;
  stats.fallbacks = static_cast<int>(out.feedback.reinitialise.size());  // isolations
  ++stats_.updates;
  stats_.last_neff = neff;
  stats_.landmarks = 0;
  for (const auto& e : estimates_) {
    stats_.landmarks += e.landmarks;
    if (!e.answered) ++stats_.missed_answers;
  }
  stats_.fallbacks += stats.fallbacks;
  return stats;
}

FilterStats DpfCoordinator::stats() const {
  FilterStats stats = stats_;
  const std::vector<DpfLocalHealth>& health = master_.health();
  const std::vector<double>& weights = master_.last().weights;
  for (size_t i = 0; i < health.size(); ++i) {
    const DpfLocalHealth& h = health[i];
    std::string state;
    if (step_ == 0) {
      state = "no step yet";
    } else if (!h.answered) {
      state = "missed the last step";
    } else if (h.probation_steps > 0) {
      state = "isolated, readmitted after " + std::to_string(h.probation_steps) + " clean steps";
    } else if (h.inconsistent) {
      state = "inconsistent (not fused)";
    } else if (h.suspect) {
      state = "suspect";
    } else {
      state = "fused";
    }
    if (i < weights.size() && step_ > 0) state += ", weight " + formatNumber(weights[i]);
    state += "; isolations " + std::to_string(h.isolations) + ", missed " +
             std::to_string(h.missed) + ", non-finite " + std::to_string(h.non_finite);
    stats.details.emplace_back("local filter " + std::to_string(i), state);
  }
  return stats;
}

PoseEstimate DpfCoordinator::estimate() const {
  PoseEstimate e;
  e.mean = master_.last().mean;
  e.covariance = master_.last().covariance;
  return e;
}

DistributedFilter::DistributedFilter(const FilterOptions& options)
    : options_(options), coordinator_(options) {
  for (int i = 0; i < options.dpf.local_filters; ++i) {
    locals_.push_back(std::make_unique<DpfLocalFilter>(options, i));
  }
  reset(Pose2::Zero());
}

void DistributedFilter::reset(const Pose2& initial_pose) {
  for (auto& local : locals_) local->reset(initial_pose);
  coordinator_.reset(initial_pose);
}

bool DistributedFilter::resetPose(const Pose2& pose, const Eigen::Matrix3d& covariance) {
  if (coordinator_.step() != 0 || !pose.allFinite() || !poseCovarianceUsable(covariance)) {
    return false;
  }
  for (auto& local : locals_) local->reset(pose, &covariance);
  coordinator_.reset(pose, covariance);
  return true;
}

void DistributedFilter::predict(const MotionInput& motion) { coordinator_.predict(motion); }

std::vector<DpfLocalEstimate> DistributedFilter::stepLocals(const DpfStepInput& input,
                                                            const std::vector<Pose2>& injected) {
  const int n = static_cast<int>(locals_.size());
  std::vector<DpfLocalEstimate> estimates(n);
  const int threads = std::min(n, options_.dpf.threads == 0 ? n : options_.dpf.threads);
  auto work = [&](int worker) {
    for (int i = worker; i < n; i += threads) estimates[i] = locals_[i]->step(input, injected[i]);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (auto& thread : pool) thread.join();
  return estimates;
}

UpdateStats DistributedFilter::update(const FeatureSet& features) {
  std::vector<Pose2> injected;
  const DpfStepInput input = coordinator_.beginStep(features, &injected);
  return coordinator_.finishStep(input, stepLocals(input, injected));
}

PoseEstimate DistributedFilter::estimate() const { return coordinator_.estimate(); }

std::vector<LandmarkEstimate> localLandmarks(const DpfLocalFilter& local) {
  std::vector<LandmarkEstimate> out;
  const auto& map = *local.particles()[local.bestParticle()].map;
  for (const auto& [id, lm] : map) {
    LandmarkEstimate e;
    e.id = id;
    e.type = LandmarkType::kPoint;
    e.mean = lm.mean;
    e.covariance = lm.covariance;
    e.observations = lm.observations;
    out.push_back(e);
  }
  return out;
}

std::vector<LandmarkEstimate> DistributedFilter::landmarks() const {
  std::vector<LandmarkEstimate> out;
  for (const auto& local : locals_) {
    const auto block = localLandmarks(*local);
    out.insert(out.end(), block.begin(), block.end());
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  return out;
}

std::vector<WeightedPose> DistributedFilter::particles() const {
  std::vector<WeightedPose> out;
  const std::vector<double>& w = coordinator_.master().last().weights;
  for (size_t i = 0; i < locals_.size(); ++i) {
    const auto& ps = locals_[i]->particles();
    const auto& pw = locals_[i]->weights();
    for (size_t j = 0; j < ps.size(); ++j) out.push_back({ps[j].pose, w[i] * pw[j]});
  }
  return out;
}

FilterStats DistributedFilter::stats() const { return coordinator_.stats(); }

}  // namespace core
}  // namespace rbpf_slam
