#include "rbpf_slam/core/filters/landmark_existence.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {

bool existenceEnabled(const ExistenceOptions& o) {
  return o.min_observations > 1 || o.visible_range_m > 0.0 || o.merge_chi2 > 0.0;
}

namespace {

bool mature(const ExistenceOptions& o, const Landmark& lm) {
  return lm.type == LandmarkType::kPoint && !lm.identified &&
         lm.observations >= o.merge_min_observations;
}

/// Adds to `removed` the duplicates among the landmarks it does not hold yet: for each pair of
/// mature point landmarks, one seen in update `step`, within ExistenceOptions::merge_chi2 of
/// each other, the less observed one (the newer on a tie). The other keeps the larger of the
/// two existence counters, and is not removed in the same update (of a chain A-B-C, where B wins
/// against A and would lose against C, A goes and B stays until a later update).
void removeDuplicates(const ExistenceOptions& o, const LandmarkMap& map, int step,
                      std::vector<bool>* removed, std::vector<int>* counters) {
  std::vector<bool> won(map.size(), false);
  std::vector<int> near;
  for (int i = 0; i < map.size(); ++i) {
    const Landmark& a = map[i];
    if ((*removed)[i] || a.last_seen_step != step || !mature(o, a)) continue;
    map.pointCandidates(a.mean, o.merge_max_distance_m, &near);
    for (int j : near) {
      const Landmark& b = map[j];
      if (j == i || (*removed)[j] || !mature(o, b)) continue;
      // A pair seen together was tested from its lower index already; whatever came of it then
      // (a removal, a failed test, a loser that had won) still holds. (On a full tie, the same
      // count and creation step, the lower index is thus the one kept; session 24 and before
      // tested the pair from both ends, and the higher index could win the second test.)
      if (j < i && b.last_seen_step == step) continue;
      const Eigen::Vector2d d = b.mean - a.mean;
      if (!(d.norm() < o.merge_max_distance_m)) continue;
      const Eigen::LLT<Eigen::Matrix2d> llt(a.covariance + b.covariance);
      if (llt.info() != Eigen::Success) continue;  // not positive definite: no test
      const double d2 = d.dot(llt.solve(d));
      if (!(d2 >= 0.0 && d2 < o.merge_chi2)) continue;
      const bool keep_a = a.observations > b.observations ||
                          (a.observations == b.observations && a.created_step <= b.created_step);
      const int winner = keep_a ? i : j, loser = keep_a ? j : i;
      if (won[loser]) continue;
      (*removed)[loser] = true;
      won[winner] = true;
      (*counters)[winner] = std::max((*counters)[winner], (*counters)[loser]);
      if (!keep_a) break;
    }
  }
}

}  // namespace

bool predictedVisible(const ExistenceOptions& o, const Pose2& pose, const Eigen::Vector2d& point) {
  if (!(o.visible_range_m > 0.0)) return false;
  const Eigen::Vector2d d = point - pose.head<2>();
  const double range = d.norm();
  if (range < o.visible_min_range_m || range > o.visible_range_m) return false;
  const double bearing = wrapAngle(std::atan2(d.y(), d.x()) - pose.z());
  return std::fabs(bearing) <= 0.5 * o.visible_fov_rad;
}

std::vector<int> landmarksToRemove(const ExistenceOptions& o, const LandmarkMap& map,
                                   const Pose2& pose, int step, std::vector<int>* counters) {
  counters->resize(map.size());
  std::vector<bool> removed(map.size(), false);
  for (int i = 0; i < map.size(); ++i) {
    const Landmark& lm = map[i];
    int count = lm.existence;
    if (lm.last_seen_step == step) {
      if (lm.created_step != step) count = std::min(count + o.sighting_count, o.max_count);
    } else if (lm.type == LandmarkType::kPoint && predictedVisible(o, pose, lm.mean)) {
      --count;  // in view, not seen: negative evidence
    }
    (*counters)[i] = count;
    const bool on_probation =
        lm.observations < o.min_observations && step - lm.created_step >= o.tentative_updates;
    removed[i] = count <= 0 || on_probation;
  }
  if (o.merge_chi2 > 0.0) removeDuplicates(o, map, step, &removed, counters);
  std::vector<int> remove;
  for (int i = 0; i < map.size(); ++i) {
    if (removed[i]) remove.push_back(i);
  }
  return remove;
}

int manageExistence(const ExistenceOptions& o, std::shared_ptr<LandmarkMap>* map, const Pose2& pose,
                    int step) {
  if (!existenceEnabled(o) || !*map) return 0;
  std::vector<int> counters;
  const std::vector<int> remove = landmarksToRemove(o, **map, pose, step, &counters);
  bool changed = !remove.empty();
  for (int i = 0; i < (*map)->size() && !changed; ++i) {
    changed = counters[i] != (**map)[i].existence;
  }
  if (!changed) return 0;
  LandmarkMap& writable = mutableMap(map);
  for (int i = 0; i < writable.size(); ++i) {
    if (counters[i] == writable[i].existence) continue;
    Landmark lm = writable[i];
    lm.existence = counters[i];
    writable.set(i, lm);
  }
  for (auto it = remove.rbegin(); it != remove.rend(); ++it) writable.remove(*it);
  return static_cast<int>(remove.size());
}

void validate(const ExistenceOptions& o) {
  requireRange("existence.min_observations", o.min_observations, 1, 1000);
  requireRange("existence.tentative_updates", o.tentative_updates, 1, 1000000);
  requireRange("existence.visible_range_m", o.visible_range_m, 0.0, 1000.0);
  if (o.visible_range_m > 0.0) {
    requireRange("existence.visible_min_range_m (at most visible_range_m)", o.visible_min_range_m,
                 0.0, o.visible_range_m);
  } else {
    requireRange("existence.visible_min_range_m", o.visible_min_range_m, 0.0, 1000.0);
  }
  requireRange("existence.visible_fov_rad", o.visible_fov_rad, 0.0, 2.0 * M_PI, true);
  requireRange("existence.max_count", o.max_count, 1, 1000000);
  requireRange("existence.sighting_count", o.sighting_count, 1, 1000000);
  requireRange("existence.merge_chi2", o.merge_chi2, 0.0, 1000.0);
  requireRange("existence.merge_min_observations", o.merge_min_observations, 1, 1000000);
  requireRange("existence.merge_max_distance_m", o.merge_max_distance_m, 0.0, 100.0, true);
}

}  // namespace core
}  // namespace rbpf_slam
