#pragma once
// A particle's landmark map, shared between particles as a persistent trie: resampling
// copies one pointer, a write copies O(log N) nodes, and a persistent grid index finds the
// landmarks near an observation without visiting the others.

#include <Eigen/Core>
#include <cmath>
#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/persistent_containers.h"
#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace core {

/// One landmark's 2D EKF: point (x, y) or line (rho, alpha) in the map frame.
struct Landmark {
  int id = -1;
  LandmarkType type = LandmarkType::kPoint;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity();
  double extent_min = 0.0;  // line: observed extent as positions along the line direction
  double extent_max = 0.0;
  int observations = 1;
  int last_seen_step = 0;
  int created_step = 0;
  int existence = 1;  // existence counter (landmark_existence.h)
  bool identified = false;  // mapped from features with a known id (never removed as a copy)
};

/// Pre-gate of a line observation against map lines (FastSlam2::associate): normals within
/// max_angle_rad and rho within max_rho_m of each other (after flipping to the same normal
/// half-plane), and the observed segment, projected on the map line, within
/// overlap_margin_m of the map line's extent.
struct LineQuery {
  Eigen::Vector2d line = Eigen::Vector2d::Zero();   // observed (rho >= 0, alpha), map frame
  Eigen::Vector2d start = Eigen::Vector2d::Zero();  // observed extent, map frame
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  double max_angle_rad = 0.5;
  double max_rho_m = 1.5;
  double overlap_margin_m = 1.0;
};

/// The landmarks of one particle, with value semantics: a copy is O(1) and shares every
/// node (persistent trie); a write copies O(log N) nodes. A spatial index of the same kind
/// (grid cell -> landmark indices) lets association visit only the landmarks near an
/// observation instead of all N.
class LandmarkMap {
 public:
  int size() const { return landmarks_.size(); }
  const Landmark& operator[](int i) const { return landmarks_[i]; }
  /// Replaces landmark i; only this map sees the change.
  void set(int i, const Landmark& landmark);
  /// Appends a landmark with index size().
  void add(const Landmark& landmark);
  /// Erases landmark i; those after it move down one index (order kept, as in a vector).
  /// O((size - i) log N): cheap for the recent landmarks at the end that are usually dropped.
  void remove(int i);

  /// Ascending, distinct indices that include every point landmark within radius_m of
  /// center (and possibly others: callers apply their exact test).
  void pointCandidates(const Eigen::Vector2d& center, double radius_m, std::vector<int>* out) const;
  /// Ascending, distinct indices that include every line landmark passing `query`'s pre-gate
  /// (and possibly others).
  void lineCandidates(const LineQuery& query, std::vector<int>* out) const;
  /// Ascending indices of every landmark with this id.
  void idCandidates(int id, std::vector<int>* out) const;

 private:
  /// The grid cells a landmark is filed under: a point in one (x, y) cell; a line in the
  /// cells of its normal-angle bin and rho cell that its extent crosses along the line.
  struct CellBox {
    int tag = 0, bin = 0, first_a = 0, last_a = 0, first_b = 0, last_b = 0;
    bool operator==(const CellBox& o) const {
      return tag == o.tag && bin == o.bin && first_a == o.first_a && last_a == o.last_a &&
             first_b == o.first_b && last_b == o.last_b;
    }
  };
  static CellBox cellsOf(const Landmark& landmark);
  void file(const CellBox& box, int index, bool insert);
  /// Looks up every cell of the box; false (nothing added) when the box has more cells than
  /// the map has landmarks, so that callers scan the map instead.
  bool collect(const CellBox& box, std::vector<int>* out) const;
  void allIndices(std::vector<int>* out) const;

  PersistentArray<Landmark> landmarks_;
  PersistentMultimap cells_;  // cell key -> landmark indices
  PersistentMultimap ids_;    // landmark id -> landmark indices
};

/// Writable access to a map that may be shared: copies the table on first write.
inline LandmarkMap& mutableMap(std::shared_ptr<LandmarkMap>* map) {
  if (!*map) {
    *map = std::make_shared<LandmarkMap>();
  } else if (map->use_count() > 1) {
    *map = std::make_shared<LandmarkMap>(**map);
  }
  return **map;
}

/// Position of point p along the direction of line (rho, alpha).
inline double alongLine(const Eigen::Vector2d& line, const Eigen::Vector2d& p) {
  return -std::sin(line.y()) * p.x() + std::cos(line.y()) * p.y();
}

/// A line's extent [*lo, *hi] (positions alongLine) after its normal turned by pi (rho < 0
/// made positive): positions along the line change sign, so the extent becomes [-hi, -lo].
inline void reverseExtent(double* lo, double* hi) {
  const double old_lo = *lo;
  *lo = -*hi;
  *hi = -old_lo;
}

/// The point of line (rho, alpha) at position s along its direction.
inline Eigen::Vector2d pointOnLine(const Eigen::Vector2d& line, double s) {
  const double c = std::cos(line.y()), si = std::sin(line.y());
  return Eigen::Vector2d(line.x() * c - s * si, line.x() * si + s * c);
}

/// Converts a landmark to the interface's estimate (line extent as end points).
LandmarkEstimate toEstimate(const Landmark& landmark);

}  // namespace core
}  // namespace rbpf_slam
