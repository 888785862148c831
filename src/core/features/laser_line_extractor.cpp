// Line and point features from a 2D laser scan: segmentation by incremental least squares
// (Yuen & MacDonald) or split-and-merge, a boundary pass, collinear merging, corners and
// isolated narrow clusters, all expressed in the base frame.

#include "rbpf_slam/core/features/laser_line_extractor.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// A run of beams [first, last] (scan indices) with the moments of the points it fits.
struct Segment {
  int first = 0;
  int last = 0;
  LineMoments moments;
};

/// Per-scan working data: beam validity, ranges and sensor-frame points.
struct ScanPoints {
  std::vector<uint8_t> valid;
  std::vector<double> range;
  std::vector<Eigen::Vector2d> point;
};

/// Distance of p to the TLS line of the moments (infinite when the line is undefined).
double distanceToLine(const LineMoments& m, const Eigen::Vector2d& p) {
  Eigen::Vector2d n;
  double offset;
  if (!m.normal(&n, &offset)) return kInf;
  return std::abs(p.dot(n) - offset);
}

/// Projection of p onto the line (rho, theta).
Eigen::Vector2d projectOnto(const LineFeature& line, const Eigen::Vector2d& p) {
  const Eigen::Vector2d n(std::cos(line.theta), std::sin(line.theta));
  return p - (p.dot(n) - line.rho) * n;
}

/// One extraction over one scan: runs, segments, boundary pass, merging, lines, points.
class Extraction {
 public:
  Extraction(const LaserExtractorOptions& options, const RangeScan& scan)
      : options_(options), scan_(scan) {}

  FeatureSet run() {
    FeatureSet features;
    features.stamp = scan_.stamp;
    const int n = static_cast<int>(scan_.ranges.size());
    if (n == 0 || !std::isfinite(scan_.angle_min) || !std::isfinite(scan_.angle_increment) ||
        !plausibleSensorMount(scan_.sensor_pose)) {
      return features;
    }
    if (!computePoints()) return features;
    segmentRuns();
    boundaryPass();
    mergeCollinear();
    filterSegments();
    mergeCollinear();
    buildLines(&features);
    if (options_.extract_clusters) findClusters(&features);
    return features;
  }

 private:
  /// Fills pts_ for every beam; returns false when no beam is valid.
  bool computePoints() {
    const int n = static_cast<int>(scan_.ranges.size());
    double upper = kInf;
    if (std::isfinite(scan_.range_max) && scan_.range_max > 0.0) upper = scan_.range_max;
    if (options_.max_range_m > 0.0) upper = std::min(upper, options_.max_range_m);
    const double lower = std::isfinite(scan_.range_min) ? scan_.range_min : 0.0;
    pts_.valid.assign(n, 0);
    pts_.range.assign(n, 0.0);
    pts_.point.resize(n);
    // Bearing angle_min + i * increment by a rotation recurrence, re-anchored every 64 beams.
    const double cd = std::cos(scan_.angle_increment), sd = std::sin(scan_.angle_increment);
    double c = 1.0, s = 0.0;
    int valid_count = 0;
    for (int i = 0; i < n; ++i) {
      if ((i & 63) == 0) {
        const double bearing = scan_.angle_min + i * scan_.angle_increment;
        c = std::cos(bearing);
        s = std::sin(bearing);
      } else {
        const double c_next = c * cd - s * sd;
        s = s * cd + c * sd;
        c = c_next;
      }
      const double r = scan_.ranges[i];
      // A reading at range_max is the "no return" of drivers that do not send +inf
      // (REP 117); the scan matcher drops it likewise.
      if (!std::isfinite(r) || r <= 0.0 || r < lower || r >= upper) continue;
      pts_.valid[i] = 1;
      pts_.range[i] = r;
      pts_.point[i] = Eigen::Vector2d(r * c, r * s);
      ++valid_count;
    }
    return valid_count > 0;
  }

  /// Splits the valid beams into runs (broken by invalid beams and by gaps larger than
  /// max_point_gap_m), then each run into line segments by the configured method.
  void segmentRuns() {
    const int n = static_cast<int>(pts_.valid.size());
    const double max_gap2 = options_.max_point_gap_m * options_.max_point_gap_m;
    const bool incremental = options_.method == "incremental";
    segments_.clear();
    segments_.reserve(32);
    int i = 0;
    while (i < n) {
      if (!pts_.valid[i]) {
        ++i;
        continue;
      }
      int last = i;
      while (last + 1 < n && pts_.valid[last + 1] &&
             (pts_.point[last + 1] - pts_.point[last]).squaredNorm() <= max_gap2) {
        ++last;
      }
      if (incremental) {
        growIncremental(i, last);
      } else {
        splitAtFarthestPoints(i, last);
      }
      i = last + 1;
    }
    if (!incremental) removeSharedSplitPoints();
  }

  /// Yuen & MacDonald incremental least squares: grow while the TLS mean squared residual
  /// (from running sums, O(1) per point) stays under max_mean_sq_residual_m2.
  void growIncremental(int first, int last) {
    Segment seg;
    seg.first = first;
    seg.moments.add(pts_.point[first]);
    for (int i = first + 1; i <= last; ++i) {
      LineMoments trial = seg.moments;
      trial.add(pts_.point[i]);
      if (trial.meanSquaredResidual() > options_.max_mean_sq_residual_m2) {
        seg.last = i - 1;
        segments_.push_back(seg);
        seg = Segment();
        seg.first = i;
        seg.moments.add(pts_.point[i]);
      } else {
        seg.moments = trial;
      }
    }
    seg.last = last;
    segments_.push_back(seg);
  }

  /// Split step of split-and-merge: split [first, last] at the point farthest from the chord
  /// while that distance exceeds split_distance_m. Leaves share their split points and come
  /// out in scan order. An explicit stack, not recursion: a sawtooth wall peels one point off
  /// per split, and a dense scan (200k beams) overflowed the call stack.
  void splitAtFarthestPoints(int first, int last) {
    std::vector<std::pair<int, int>> pending{{first, last}};
    while (!pending.empty()) {
      const auto [a_index, b_index] = pending.back();
      pending.pop_back();
      int split = -1;
      if (b_index - a_index >= 2) {
        const Eigen::Vector2d& a = pts_.point[a_index];
        const Eigen::Vector2d chord = pts_.point[b_index] - a;
        const double length = chord.norm();
        double best = options_.split_distance_m;
        for (int k = a_index + 1; k < b_index; ++k) {
          const Eigen::Vector2d d = pts_.point[k] - a;
          const double dist =
              length > 0.0 ? std::abs(chord.x() * d.y() - chord.y() * d.x()) / length : d.norm();
          if (dist > best) {
            best = dist;
            split = k;
          }
        }
      }
      if (split < 0) {
        Segment seg;
        seg.first = a_index;
        seg.last = b_index;
        segments_.push_back(seg);
        continue;
      }
      pending.emplace_back(split, b_index);  // the right half after the left one
      pending.emplace_back(a_index, split);
    }
  }

  /// Gives each shared split point to the earlier leaf (the boundary pass may move it),
  /// and fills the moments of the leaves.
  void removeSharedSplitPoints() {
    for (size_t k = 1; k < segments_.size(); ++k) {
      if (segments_[k].first == segments_[k - 1].last) ++segments_[k].first;
    }
    for (Segment& seg : segments_) {
      for (int i = seg.first; i <= seg.last; ++i) seg.moments.add(pts_.point[i]);
    }
  }

  /// Moves end points between touching segments to the segment whose line fits them better.
  void boundaryPass() {
    for (size_t k = 1; k < segments_.size(); ++k) {
      Segment& a = segments_[k - 1];
      Segment& b = segments_[k];
      if (a.last + 1 != b.first || a.first > a.last || b.first > b.last) continue;
      const int max_moves = (a.last - a.first) + (b.last - b.first) + 2;
      for (int move = 0; move < max_moves; ++move) {
        if (a.moments.n > 2.0 && b.moments.n >= 2.0) {
          const Eigen::Vector2d& p = pts_.point[a.last];
          if (distanceToLine(b.moments, p) < distanceToLine(a.moments, p)) {
            a.moments.remove(p);
            b.moments.add(p);
            --a.last;
            --b.first;
            continue;
          }
        }
        if (b.moments.n > 2.0 && a.moments.n >= 2.0) {
          const Eigen::Vector2d& p = pts_.point[b.first];
          if (distanceToLine(a.moments, p) < distanceToLine(b.moments, p)) {
            b.moments.remove(p);
            a.moments.add(p);
            ++a.last;
            ++b.first;
            continue;
          }
        }
        break;
      }
    }
  }

  /// True when two segments lie on one line: directions within merge_angle_rad, and the
  /// centroid of the less certain segment (smaller spread along its line) within
  /// merge_distance_m of the line of the other (a short segment's own line, extrapolated,
  /// would exaggerate the offset).
  bool collinear(const Segment& a, const Segment& b) const {
    Eigen::Vector2d na, nb;
    double oa, ob;
    if (!a.moments.normal(&na, &oa) || !b.moments.normal(&nb, &ob)) return false;
    if (std::abs(na.dot(nb)) < std::cos(options_.merge_angle_rad)) return false;
    const bool a_certain = a.moments.spread() >= b.moments.spread();
    const LineMoments& small = a_certain ? b.moments : a.moments;
    const Eigen::Vector2d& n = a_certain ? na : nb;
    const double offset = a_certain ? oa : ob;
    const Eigen::Vector2d centroid(small.sx / small.n, small.sy / small.n);
    return std::abs(centroid.dot(n) - offset) <= options_.merge_distance_m;
  }

  /// Merges neighbouring segments (in scan order) that are collinear; the fit is refitted
  /// from the summed moments.
  void mergeCollinear() {
    if (segments_.size() < 2) return;
    size_t out = 0;
    for (size_t k = 1; k < segments_.size(); ++k) {
      if (collinear(segments_[out], segments_[k])) {
        segments_[out].moments += segments_[k].moments;
        segments_[out].last = segments_[k].last;
      } else {
        segments_[++out] = segments_[k];
      }
    }
    segments_.resize(out + 1);
  }

  /// Drops segments with too few points or too short an extent.
  void filterSegments() {
    size_t out = 0;
    for (const Segment& seg : segments_) {
      if (seg.moments.n < options_.min_points_per_line || seg.moments.n < 2.0) continue;
      LineFeature line;
      if (!seg.moments.fit(options_.sigma_range_m, &line)) continue;
      const double length =
          (projectOnto(line, pts_.point[seg.last]) - projectOnto(line, pts_.point[seg.first]))
              .norm();
      if (length < options_.min_line_length_m) continue;
      segments_[out++] = seg;
    }
    segments_.resize(out);
  }

  /// Fits the final lines, finds corners between neighbouring lines, and emits both in the
  /// base frame.
  void buildLines(FeatureSet* features) {
    const Pose2& pose = scan_.sensor_pose;
    std::vector<LineFeature>& lines = features->lines;
    lines.reserve(segments_.size());
    const size_t first_line = lines.size();
    for (const Segment& seg : segments_) {
      LineFeature line;
      if (!seg.moments.fit(options_.sigma_range_m, &line)) continue;
      line.start = projectOnto(line, pts_.point[seg.first]);
      line.end = projectOnto(line, pts_.point[seg.last]);
      lines.push_back(line);  // sensor frame for now
    }
    if (options_.extract_corners) {
      const double cos_min = std::cos(options_.corner_min_angle_rad);
      for (size_t k = first_line + 1; k < lines.size(); ++k) {
        const LineFeature& a = lines[k - 1];
        const LineFeature& b = lines[k];
        if ((a.end - b.start).norm() > options_.corner_max_gap_m) continue;
        if (std::abs(std::cos(a.theta - b.theta)) > cos_min) continue;
        const double det = std::sin(b.theta - a.theta);
        if (std::abs(det) < 1e-9) continue;
        // Solve [cos a, sin a; cos b, sin b] p = [rho_a; rho_b].
        const Eigen::Vector2d corner((a.rho * std::sin(b.theta) - b.rho * std::sin(a.theta)) / det,
                                     (b.rho * std::cos(a.theta) - a.rho * std::cos(b.theta)) / det);
        const double reach = 2.0 * options_.corner_max_gap_m + 1e-6;
        if ((corner - a.end).norm() > reach || (corner - b.start).norm() > reach) continue;
        addPoint(corner, features);
      }
    }
    for (size_t k = first_line; k < lines.size(); ++k) {
      lines[k] = transformLineFeature(pose, lines[k]);
    }
  }

  /// Adds a sensor-frame point as a base-frame range/bearing feature.
  void addPoint(const Eigen::Vector2d& p, FeatureSet* features) const {
    PointFeature f;
    f.range = p.norm();
    if (!(f.range > 1e-9)) return;
    f.bearing = std::atan2(p.y(), p.x());
    f.covariance << options_.sigma_point_range_m * options_.sigma_point_range_m, 0.0, 0.0,
        options_.sigma_point_bearing_rad * options_.sigma_point_bearing_rad;
    f.id = -1;
    PointFeature base = transformPointFeature(scan_.sensor_pose, f);
    if (!(base.range > 1e-9) || !std::isfinite(base.range) || !std::isfinite(base.bearing) ||
        !base.covariance.allFinite()) {
      return;
    }
    features->points.push_back(base);
  }

  /// True when the beam beside an end of a cluster (step = -1 or +1 from index end) shows
  /// the cluster isolated: a deeper return by cluster_isolation_m, or only invalid beams up
  /// to a return that is deeper or farther away than cluster_isolation_m (or the scan edge).
  bool isolatedSide(int end, int step) const {
    const int n = static_cast<int>(pts_.valid.size());
    const double isolation = options_.cluster_isolation_m;
    int i = end + step;
    if (i < 0 || i >= n) return false;  // the scan edge may hide the rest of a wall
    if (pts_.valid[i]) return pts_.range[i] - pts_.range[end] >= isolation;
    while (i >= 0 && i < n && !pts_.valid[i]) i += step;
    if (i < 0 || i >= n) return true;
    return pts_.range[i] - pts_.range[end] >= isolation ||
           (pts_.point[i] - pts_.point[end]).norm() > isolation;
  }

  /// Isolated narrow clusters (posts, legs, trunks): runs of close consecutive points that
  /// are nearer than both neighbours, reported at the centroid pushed back by pi/4 of the
  /// half-width (the mean depth of a circle's visible half).
  void findClusters(FeatureSet* features) const {
    const int n = static_cast<int>(pts_.valid.size());
    const double isolation = options_.cluster_isolation_m;
    const double max_gap2 = options_.max_point_gap_m * options_.max_point_gap_m;
    int i = 0;
    while (i < n) {
      if (!pts_.valid[i]) {
        ++i;
        continue;
      }
      int last = i;
      while (last + 1 < n && pts_.valid[last + 1] &&
             std::abs(pts_.range[last + 1] - pts_.range[last]) < isolation &&
             (pts_.point[last + 1] - pts_.point[last]).squaredNorm() <= max_gap2) {
        ++last;
      }
      const int count = last - i + 1;
      const double width = (pts_.point[last] - pts_.point[i]).norm();
      if (count >= options_.cluster_min_points && width <= options_.cluster_max_width_m &&
          isolatedSide(i, -1) && isolatedSide(last, +1)) {
        Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
        for (int k = i; k <= last; ++k) centroid += pts_.point[k];
        centroid /= count;
        const double r = centroid.norm();
        if (r > 1e-9) centroid *= (r + 0.25 * M_PI * 0.5 * width) / r;
        addPoint(centroid, features);
      }
      i = last + 1;
    }
  }

  const LaserExtractorOptions& options_;
  const RangeScan& scan_;
  ScanPoints pts_;
  std::vector<Segment> segments_;
};

}  // namespace

void validate(const LaserExtractorOptions& o) {
  requireOneOf("laser_features.method", o.method, {"incremental", "split_and_merge"});
  requireRange("laser_features.sigma_range_m", o.sigma_range_m, 0.0, 10.0, true);
  requireRange("laser_features.max_mean_sq_residual_m2", o.max_mean_sq_residual_m2, 0.0, 1.0, true);
  requireRange("laser_features.split_distance_m", o.split_distance_m, 0.0, 10.0, true);
  requireRange("laser_features.max_point_gap_m", o.max_point_gap_m, 0.0, 100.0, true);
  requireRange("laser_features.min_points_per_line", o.min_points_per_line, 2, 100000);
  requireRange("laser_features.min_line_length_m", o.min_line_length_m, 0.0, 1000.0);
  requireRange("laser_features.merge_angle_rad", o.merge_angle_rad, 0.0, 0.5 * M_PI);
  requireRange("laser_features.merge_distance_m", o.merge_distance_m, 0.0, 10.0);
  requireRange("laser_features.corner_min_angle_rad", o.corner_min_angle_rad, 0.0, 0.5 * M_PI);
  requireRange("laser_features.corner_max_gap_m", o.corner_max_gap_m, 0.0, 10.0);
  requireRange("laser_features.cluster_max_width_m", o.cluster_max_width_m, 0.0, 10.0, true);
  requireRange("laser_features.cluster_min_points", o.cluster_min_points, 1, 100000);
  requireRange("laser_features.cluster_isolation_m", o.cluster_isolation_m, 0.0, 100.0, true);
  requireRange("laser_features.sigma_point_range_m", o.sigma_point_range_m, 0.0, 10.0, true);
  requireRange("laser_features.sigma_point_bearing_rad", o.sigma_point_bearing_rad, 0.0, M_PI, true);
  requireRange("laser_features.max_range_m", o.max_range_m, 0.0, 1e6);
}

LaserLineExtractor::LaserLineExtractor(const LaserExtractorOptions& options) : options_(options) {
  validate(options_);
}

FeatureSet LaserLineExtractor::extract(const RangeScan& scan) const {
  return Extraction(options_, scan).run();
}

}  // namespace core
}  // namespace rbpf_slam
