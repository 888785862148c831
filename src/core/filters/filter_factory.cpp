#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "rbpf_slam/core/alignment.h"
#include "rbpf_slam/core/filters/distributed_filter.h"
#include "rbpf_slam/core/filters/ekf_slam.h"
#include "rbpf_slam/core/filters/ensemble_filter.h"
#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/fault_injector.h"
#include "rbpf_slam/core/filters/hinf_fastslam.h"
#include "rbpf_slam/core/filters/landmark_existence.h"
#include "rbpf_slam/core/filters/multifilter_smc.h"
#include "rbpf_slam/core/filters/robust_fastslam2.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/grid/grid_pf.h"
#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {
namespace {

}  // namespace

std::vector<std::string> availableVariants() {
  return {"fastslam2", "robust_fastslam2", "hinf_fastslam", "multifilter_smc", "ekf_slam",
          "grid_pf", "dpf"};
}

void validate(const RobustOptions& o) {
  requireRange("robust.ancestor_sets", o.ancestor_sets, 1, 100);
  requireRange("robust.ancestor_spacing_steps", o.ancestor_spacing_steps, 1, 100000);
  requireRange("robust.window_steps", o.window_steps, 1, 100000);
  requireRange("robust.min_old_observations", o.min_old_observations, 0, 1000);
  requireRange("robust.path_iterations", o.path_iterations, 1, 100);
}

void validate(const FilterOptions& o) {
  requireOneOf("variant", o.variant, availableVariants());
  if (o.heading_prior.enabled && o.variant != "fastslam2" && o.variant != "hinf_fastslam" &&
      o.variant != "robust_fastslam2") {
    throw std::invalid_argument("heading_prior.enabled = true is not implemented for variant '" +
                                o.variant + "' (fastslam2, hinf_fastslam, robust_fastslam2 only)");
  }
  requireRange("particles", o.particles, 1, 100000);
  requireRange("ensemble.members", o.ensemble.members, 1, 64);
  requireOneOf("ensemble.rank_by", o.ensemble.rank_by, {"evidence", "new_landmarks", "consensus"});
  requireRange("ensemble.consensus_period", o.ensemble.consensus_period, 1, 1000000);
  requireRange("ensemble.consensus_margin_m", o.ensemble.consensus_margin_m, 0.0, 1e6);
  requireRange("ensemble.consensus_max_poses", o.ensemble.consensus_max_poses, 10, 100000000);
  requireRange("ensemble.switch_margin", o.ensemble.switch_margin, 0.0, 1e6);
  if (o.ensemble.members > 1 && o.variant != "fastslam2" && o.variant != "hinf_fastslam") {
    throw std::invalid_argument("ensemble.members > 1 is not implemented for variant '" +
                                o.variant + "' (fastslam2, hinf_fastslam only: the members are "
                                "ranked by the marginal likelihood these estimate)");
  }
  {
    // Each bound alone let 100000 particles x 64 members through: 8 GB, then std::bad_alloc
    // naming nothing.
    const long members = o.ensemble.members;
    // dpf: one set per local filter; robust_fastslam2: M x K candidates at a robust step.
    const long locals = o.variant == "dpf"                ? std::max(1, o.dpf.local_filters)
                        : o.variant == "robust_fastslam2" ? std::max(1, o.robust.ancestor_sets)
                                                          : 1;
    const long total = static_cast<long>(o.particles) * members * locals;
    constexpr long kMaxTotalParticles = 200000;
    if (total > kMaxTotalParticles) {
      throw std::invalid_argument("particles x ensemble.members" +
                                  std::string(locals == 1          ? ""
                                              : o.variant == "dpf" ? " x dpf.local_filters"
                                                                   : " x robust.ancestor_sets") +
                                  " = " + std::to_string(total) + " is above " +
                                  std::to_string(kMaxTotalParticles) +
                                  " (each particle holds a map: gigabytes); lower one of them");
    }
  }
  if (o.ensemble.members > 1 && o.dpf.fault.enabled) {
    throw std::invalid_argument("ensemble.members > 1 with fault.enabled is not implemented "
                                "(each member would draw its own fault)");
  }
  requireRange("resample_threshold", o.resample_threshold, 0.0, 1.0);
  requireRange("proposal_sample_scale", o.proposal_sample_scale, 1e-3, 1.0);
  requireRange("association.gate_chi2", o.association.gate_chi2, 0.1, 1000.0);
  requireRange("association.new_landmark_chi2", o.association.new_landmark_chi2,
               o.association.gate_chi2, 1000.0);
  requireRange("association.line_overlap_margin_m", o.association.line_overlap_margin_m, 0.0, 100.0);
  requireOneOf("association.sample_weight", o.association.sample_weight, {"sum", "max"});
  requireOneOf("association.ambiguous_weight", o.association.ambiguous_weight, {"none", "soft"});
  requireRange("measurement.sigma_range_m", o.measurement.sigma_range_m, 1e-6, 100.0);
  requireRange("measurement.sigma_bearing_rad", o.measurement.sigma_bearing_rad, 1e-6, M_PI);
  requireRange("measurement.sigma_rho_m", o.measurement.sigma_rho_m, 1e-6, 100.0);
  requireRange("measurement.sigma_theta_rad", o.measurement.sigma_theta_rad, 1e-6, M_PI);
  requireRange("measurement.covariance_inflation", o.measurement.covariance_inflation, 1e-3, 1e3);
  requireRange("measurement.landmark_iterations", o.measurement.landmark_iterations, 1, 100);
  if (!o.use_points && !o.use_lines) {
    throw std::invalid_argument("use_points and use_lines are both false: nothing to map");
  }
  validate(o.motion);
  validate(o.robust);
  validate(o.tracker);
  validate(o.existence);
  validate(o.relocalization);
  validate(o.heading_prior);
  validate(o.hinf);
  validate(o.line_association);
  validate(o.multifilter);
  validate(o.ekf);
  validate(o.grid);
  requireKldCountFits(o.grid, o.particles);
  validate(o.dpf);
}

std::vector<Pose2> SlamFilter::bestPathSample(std::size_t max_poses, std::size_t* length) const {
  const std::vector<Pose2> path = bestPath();
  if (length) *length = path.size();
  return evenlySpacedPoses(path, max_poses);
}

std::unique_ptr<SlamFilter> createFilter(const FilterOptions& options) {
  validate(options);
  if (options.ensemble.members > 1) return createEnsembleFilter(options);
  if (options.dpf.fault.enabled && options.variant != "dpf") return createFaultInjectedFilter(options);
  if (options.variant == "dpf") return std::make_unique<DistributedFilter>(options);
  if (options.variant == "fastslam2") return std::make_unique<FastSlam2>(options);
  if (options.variant == "robust_fastslam2") return std::make_unique<RobustFastSlam2>(options);
  if (options.variant == "hinf_fastslam") return std::make_unique<HinfFastSlam>(options);
  if (options.variant == "multifilter_smc") return std::make_unique<MultiFilterSmc>(options);
  if (options.variant == "ekf_slam") return std::make_unique<EkfSlam>(options);
  if (options.variant == "grid_pf") return std::make_unique<GridParticleFilter>(options);
  throw std::invalid_argument("variant = '" + options.variant + "' is not implemented");
}

}  // namespace core
}  // namespace rbpf_slam
