#pragma once
// Ideal sensor models of the simulator, as pure functions of the pose and the geometry, with
// Gaussian noise drawn from a caller-owned generator (null: noise-free).

#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/random.h"
#include "rbpf_slam/core/sim/ray_caster.h"
#include "rbpf_slam/core/sim/world.h"

namespace rbpf_slam {
namespace core {
namespace sim {

/// The laser's mounting pose in the base frame.
Pose2 laserMountPose(const LaserConfig& config);

/// One laser scan taken with the base at base_pose (map frame); no return is +inf.
RangeScan simulateLaserScan(const LaserConfig& config, const RayCaster& caster,
                            const Pose2& base_pose, Rng* rng);

/// The range of one cone sensor (sonar, infrared) whose pose in the map is sensor_pose: the
/// nearest surface hit inside the cone at an incidence below the critical angle, or the
/// nearest visible vertex when corner echoes are on; max_range_m when there is no echo.
double simulateConeRange(const RingSensorConfig& config, const RayCaster& caster,
                         const Pose2& sensor_pose, Rng* rng);

/// Range-bearing observations (base frame) of the landmarks in range, in the field of view
/// and, when config.occlusion is set, not hidden by the caster's geometry.
FeatureSet observeLandmarks(const RangeBearingConfig& config,
                            const std::vector<Landmark>& landmarks, const RayCaster& caster,
                            const Pose2& base_pose, Rng* rng);

}  // namespace sim
}  // namespace core
}  // namespace rbpf_slam
