#pragma once
// Landmark existence management shared by the FastSLAM variants (Montemerlo's
// thesis, sec. 5.3: negative evidence): a counter per landmark, raised by each
// sighting, lowered each time the landmark lies in the sensor's view and was
// not seen; and a probation for new landmarks.

#include <vector>

#include "rbpf_slam/core/filters/filter_options.h"
#include "rbpf_slam/core/filters/landmark_map.h"
#include "rbpf_slam/core/geometry.h"

namespace rbpf_slam {
namespace core {

/// True when the options prune anything at all.
bool existenceEnabled(const ExistenceOptions& options);

/// True when point landmark `point` lies inside the field of view of `pose`.
bool predictedVisible(const ExistenceOptions& options, const Pose2& pose,
                      const Eigen::Vector2d& point);

/// Indices of the landmarks to remove from `map` after update `step` at `pose`
/// (ascending). Landmarks with last_seen_step == step were seen in this update.
/// Also returns, through `counters`, the new existence counter of every
/// landmark (same order as the map).
std::vector<int> landmarksToRemove(const ExistenceOptions& options, const LandmarkMap& map,
                                   const Pose2& pose, int step, std::vector<int>* counters);

/// Applies one update's existence bookkeeping to a particle's map; copies the
/// map only when something changes. Returns the number of landmarks removed.
int manageExistence(const ExistenceOptions& options, std::shared_ptr<LandmarkMap>* map,
                    const Pose2& pose, int step);

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const ExistenceOptions& options);

}  // namespace core
}  // namespace rbpf_slam
