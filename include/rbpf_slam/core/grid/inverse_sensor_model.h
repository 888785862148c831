#pragma once
// Inverse sensor models of the occupancy grid (Yatim and Buniyamin 2015, eq. 13): what one
// observation says about the cells around the robot, as a local map in the base frame that
// every particle then places at its own pose.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"
#include "rbpf_slam/core/grid/grid_options.h"

namespace rbpf_slam {
namespace core {

/// A cell of the local map (base frame), seen occupied or free.
struct LocalMapCell {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  bool occupied = false;
};

/// Collects free and occupied marks on a grid of the map's resolution in the base frame; a
/// cell marked both ways is occupied (the hit is the information, the pass-through the guess).
class LocalMapBuilder {
 public:
  explicit LocalMapBuilder(double resolution_m);
  void mark(const Eigen::Vector2d& p, bool occupied);
  /// One entry per marked cell, at its centre; the builder is empty afterwards.
  std::vector<LocalMapCell> finish();

 private:
  double resolution_m_;
  std::vector<std::pair<int64_t, bool>> marks_;
};

/// What buildLocalMap used and skipped.
struct LocalMapStats {
  int readings = 0;   // cone readings and laser beams offered
  int echoes = 0;     // ... with a hit (occupied cells)
  int no_echo = 0;    // ... without (free cells only)
  int rejected = 0;   // ... NaN, negative, below min range or with an unusable cone
  int beyond_reach = 0;  // ... with an echo beyond the first extent's diagonal (cones: among
                         // the rejected; laser beams: traced as free up to it)
};

/// Cone sensor (sonar, infrared): the arc at the range occupied, the cone inside it free; a
/// reading at max range (no echo) frees the cone only. Returns false when it was rejected.
bool addConeReading(const ConeReading& reading, const GridOptions& options,
                    LocalMapBuilder* builder, LocalMapStats* stats);
/// Laser: every beam frees the cells it crosses and occupies its end cell.
void addRangeScan(const RangeScan& scan, const GridOptions& options, LocalMapBuilder* builder,
                  LocalMapStats* stats);
/// The local map of a whole observation (its scan and its cone readings).
std::vector<LocalMapCell> buildLocalMap(const FeatureSet& features, const GridOptions& options,
                                        LocalMapStats* stats);

}  // namespace core
}  // namespace rbpf_slam
