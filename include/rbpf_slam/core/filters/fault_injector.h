#pragma once
// Disturbance noise for robustness experiments: from a given step on, each filter step's
// odometry increment gets an extra N(0, sigma^2) the filter's motion model does not know of.

#include <memory>

#include "rbpf_slam/core/filters/dpf_options.h"
#include "rbpf_slam/core/filters/slam_filter.h"
#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {

/// The disturbance sequence; the same seed and options give the same draws whichever filter
/// they disturb (so the distributed and the centralised filters see the same fault).
class FaultInjector {
 public:
  FaultInjector(const FaultInjectorOptions& options, unsigned long seed);
  void reset();
  /// The disturbance of step (1-based); zero before start_step or when disabled.
  Pose2 disturbance(long step);

 private:
  const FaultInjectorOptions options_;
  const unsigned long seed_;
  Rng rng_;
};

/// Any filter with a FaultInjector in its process (the centralised comparison).
std::unique_ptr<SlamFilter> createFaultInjectedFilter(const FilterOptions& options);

}  // namespace core
}  // namespace rbpf_slam
