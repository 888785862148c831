#include "rbpf_slam/core/features/scan_matcher.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {
namespace {

/// A uniform grid over the reference points for nearest-neighbour queries: a dense array of
/// cells over their bounding box (each cell's points contiguous, in index order), or a hash
/// map when the box is too sparse for an array.
class PointGrid {
 public:
  PointGrid(const std::vector<Eigen::Vector2d>& points, double cell)
      : points_(points), cell_(cell) {
    if (points.empty()) return;
    min_x_ = max_x_ = cellOf(points[0].x());
    min_y_ = max_y_ = cellOf(points[0].y());
    for (const Eigen::Vector2d& p : points) {
      min_x_ = std::min(min_x_, cellOf(p.x()));
      max_x_ = std::max(max_x_, cellOf(p.x()));
      min_y_ = std::min(min_y_, cellOf(p.y()));
      max_y_ = std::max(max_y_, cellOf(p.y()));
    }
    const double cells = (static_cast<double>(max_x_) - min_x_ + 1) * (static_cast<double>(max_y_) - min_y_ + 1);
    dense_ = cells <= 16.0 * points.size() + 4096.0;
    if (!dense_) {
      for (size_t i = 0; i < points.size(); ++i) cells_[key(cellOf(points[i].x()), cellOf(points[i].y()))].push_back(static_cast<int>(i));
      return;
    }
    // Counting sort into contiguous cells; a stable pass keeps each cell in index order.
    width_ = max_x_ - min_x_ + 1;
    start_.assign(static_cast<size_t>(cells) + 1, 0);
    for (const Eigen::Vector2d& p : points) ++start_[denseIndex(cellOf(p.x()), cellOf(p.y())) + 1];
    for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    order_.resize(points.size());
    std::vector<int> fill(start_.begin(), start_.end() - 1);
    for (size_t i = 0; i < points.size(); ++i) {
      order_[fill[denseIndex(cellOf(points[i].x()), cellOf(points[i].y()))]++] = static_cast<int>(i);
    }
  }
  /// Index of the nearest point within radius (at most one cell), or -1; among equally near
  /// points, the first by cell (x then y offset) and index.
  int nearest(const Eigen::Vector2d& q, double radius, double* distance2) const {
    const long cx = cellOf(q.x()), cy = cellOf(q.y());
    int best = -1;
    double best_d2 = radius * radius;
    const auto visit = [&](int i) {
      const double d2 = (points_[i] - q).squaredNorm();
      if (d2 < best_d2) {
        best_d2 = d2;
        best = i;
      }
    };
    // Cells entirely beyond the radius cannot hold a nearer point (a margin covers points
    // that rounding filed in a neighbouring cell): skipping them changes no result.
    const double margin = 1e-9 * (1.0 + std::fabs(q.x()) + std::fabs(q.y())) + 1e-12;
    const double reach2 = (radius + margin) * (radius + margin);
    for (long dx = -1; dx <= 1; ++dx) {
      const double gap_x = std::max({(cx + dx) * cell_ - q.x(), q.x() - (cx + dx + 1) * cell_, 0.0});
      for (long dy = -1; dy <= 1; ++dy) {
        const double gap_y = std::max({(cy + dy) * cell_ - q.y(), q.y() - (cy + dy + 1) * cell_, 0.0});
        if (gap_x * gap_x + gap_y * gap_y > reach2) continue;
        const long x = cx + dx, y = cy + dy;
        if (dense_) {
          if (x < min_x_ || x > max_x_ || y < min_y_ || y > max_y_) continue;
          const long c = denseIndex(x, y);
          for (int k = start_[c]; k < start_[c + 1]; ++k) visit(order_[k]);
          continue;
        }
        const auto it = cells_.find(key(x, y));
        if (it == cells_.end()) continue;
        for (int i : it->second) visit(i);
      }
    }
    *distance2 = best_d2;
    return best;
  }

 private:
  long cellOf(double v) const { return static_cast<long>(std::floor(v / cell_)); }
  long denseIndex(long x, long y) const { return (y - min_y_) * width_ + (x - min_x_); }
  static long long key(long x, long y) {
    return static_cast<long long>((static_cast<unsigned long long>(x) << 32) ^
                                  (static_cast<unsigned long long>(y) & 0xffffffffULL));
  }
  const std::vector<Eigen::Vector2d>& points_;
  const double cell_;
  bool dense_ = true;
  long min_x_ = 0, max_x_ = -1, min_y_ = 0, max_y_ = -1, width_ = 0;
  std::vector<int> start_;  // dense: cell c holds order_[start_[c] .. start_[c + 1])
  std::vector<int> order_;
  std::unordered_map<long long, std::vector<int>> cells_;  // sparse
};

/// Unit normals of the reference from each point's neighbours (zero where undefined).
std::vector<Eigen::Vector2d> normalsOf(const std::vector<Eigen::Vector2d>& points) {
  std::vector<Eigen::Vector2d> normals(points.size(), Eigen::Vector2d::Zero());
  for (size_t i = 1; i + 1 < points.size(); ++i) {
    const Eigen::Vector2d a = points[i - 1], b = points[i + 1];
    if ((a - points[i]).norm() > 0.5 || (b - points[i]).norm() > 0.5) continue;
    const Eigen::Vector2d d = b - a;
    if (d.norm() < 1e-6) continue;
    normals[i] = Eigen::Vector2d(-d.y(), d.x()).normalized();
  }
  return normals;
}

}  // namespace

void validate(const ScanMatcherOptions& o) {
  requireRange("scan_matching.max_iterations", o.max_iterations, 1, 1000);
  requireRange("scan_matching.max_correspondence_m", o.max_correspondence_m, 1e-3, 10.0);
  requireRange("scan_matching.min_correspondence_m", o.min_correspondence_m, 1e-3,
               o.max_correspondence_m);
  requireRange("scan_matching.min_inlier_ratio", o.min_inlier_ratio, 0.0, 1.0);
  requireRange("scan_matching.max_residual_rms_m", o.max_residual_rms_m, 1e-4, 10.0);
  requireRange("scan_matching.max_range_m", o.max_range_m, 0.1, 1000.0);
  requireRange("scan_matching.rotation_guess_rad", o.rotation_guess_rad, 0.0, 1.6);
  requireRange("scan_matching.search_below_inlier_ratio", o.search_below_inlier_ratio, 0.0, 1.0);
  requireRange("scan_matching.search_step_rad", o.search_step_rad, 0.01, 1.6);
  requireRange("scan_matching.min_information", o.min_information, 0.0, 1e9);
  requireRange("scan_matching.max_correction_m", o.max_correction_m, 0.0, 100.0);
  requireRange("scan_matching.max_correction_rad", o.max_correction_rad, 0.0, 3.2);
  requireRange("scan_matching.noise_scale", o.noise_scale, 1e-3, 10.0);
  requireRange("scan_matching.degenerate_noise_scale", o.degenerate_noise_scale, 1e-3, 10.0);
  requireRange("scan_matching.submap_scans", o.submap_scans, 1, 100);
  requireRange("scan_matching.prior_weight_xy", o.prior_weight_xy, 0.0, 1e6);
  requireRange("scan_matching.prior_weight_theta", o.prior_weight_theta, 0.0, 1e6);
}

std::vector<Eigen::Vector2d> scanPointsInBase(const RangeScan& scan, double max_range_m) {
  std::vector<Eigen::Vector2d> points;
  if (!plausibleSensorMount(scan.sensor_pose)) return points;  // as the line extractor does
  points.reserve(scan.ranges.size());
  const double upper = std::isfinite(scan.range_max) && scan.range_max > 0.0
                           ? std::min(scan.range_max, max_range_m)
                           : max_range_m;
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    const double r = scan.ranges[i];
    if (!std::isfinite(r) || r <= 0.0 || r < scan.range_min || r >= upper) continue;
    const double a = scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    if (!std::isfinite(a)) continue;  // a broken header (NaN or inf angles): no usable beam
    const Eigen::Vector2d p =
        transformPoint(scan.sensor_pose, Eigen::Vector2d(r * std::cos(a), r * std::sin(a)));
    if (p.allFinite()) points.push_back(p);
  }
  return points;
}

ScanMatcher::ScanMatcher(const ScanMatcherOptions& options) : options_(options) {
  validate(options_);
}

double ScanMatcher::noiseScale(const ScanMatchResult& result) const {
  return result.degenerate ? options_.degenerate_noise_scale : options_.noise_scale;
}

ScanMatchResult ScanMatcher::match(const std::vector<Eigen::Vector2d>& reference,
                                   const std::vector<Eigen::Vector2d>& current,
                                   const Pose2& initial_delta) const {
  ScanMatchResult best;
  if (reference.size() < 10 || current.size() < 10 || !initial_delta.allFinite()) return best;
  const std::vector<Eigen::Vector2d> normals = normalsOf(reference);
  best = matchSearching(reference, normals, current, initial_delta);
  // From odometry first; only if that fails, from rest: wheel odometry has glitches (repeated
  // or out-of-order stamps put the Intel log's odometry 4.5 m off between two scans), and
  // then a start at the odometry guess cannot converge or is rejected as too far from it.
  if (!best.ok) {
    const ScanMatchResult from_rest = matchFromRest(reference, normals, current);
    if (from_rest.ok) best = from_rest;
  }
  return best;
}

ScanMatchResult ScanMatcher::matchSearching(const std::vector<Eigen::Vector2d>& reference,
                                            const std::vector<Eigen::Vector2d>& normals,
                                            const std::vector<Eigen::Vector2d>& current,
                                            const Pose2& guess) const {
  ScanMatchResult best = matchAround(reference, normals, current, guess);
  // Wheel odometry can be 15-25 deg off over one in-place turn (Intel, ACES); ICP converges
  // only within a few degrees, so a start 10 deg off ends in a wrong minimum that still pairs
  // a quarter of the points. A poor or failed match is retried from a fan of rotations.
  if (options_.search_below_inlier_ratio > 0.0 &&
      (!best.ok || best.inlier_ratio < options_.search_below_inlier_ratio)) {
    std::vector<double> offsets;
    const int n =
        static_cast<int>(std::floor(options_.max_correction_rad / options_.search_step_rad));
    for (int k = -n; k <= n; ++k) offsets.push_back(k * options_.search_step_rad);
    const ScanMatchResult searched = matchFromStarts(reference, normals, current, guess, offsets);
    if (searched.ok && (!best.ok || score(searched) > score(best))) best = searched;
  }
  return best;
}

ScanMatchResult ScanMatcher::matchFromRest(const std::vector<Eigen::Vector2d>& reference,
                                           const std::vector<Eigen::Vector2d>& current) const {
  if (reference.size() < 10 || current.size() < 10) return ScanMatchResult();
  return matchFromRest(reference, normalsOf(reference), current);
}

ScanMatchResult ScanMatcher::matchFromRest(const std::vector<Eigen::Vector2d>& reference,
                                           const std::vector<Eigen::Vector2d>& normals,
                                           const std::vector<Eigen::Vector2d>& current) const {
  // The same rotation search as from odometry: a glitch comes with a wrong turn too.
  ScanMatchResult result = matchSearching(reference, normals, current, Pose2::Zero());
  result.from_rest = true;
  // Degenerate (a corridor): the motion along it would be the start's zero, not a measurement.
  if (result.degenerate) result.ok = false;
  return result;
}

double ScanMatcher::score(const ScanMatchResult& r) {
  return (r.ok ? 10.0 : 0.0) + r.inlier_ratio - r.residual_rms_m;
}

ScanMatchResult ScanMatcher::matchAround(const std::vector<Eigen::Vector2d>& reference,
                                         const std::vector<Eigen::Vector2d>& normals,
                                         const std::vector<Eigen::Vector2d>& current,
                                         const Pose2& guess) const {
  std::vector<double> offsets{0.0};
  if (options_.rotation_guess_rad > 0.0) {
    offsets.push_back(-options_.rotation_guess_rad);
    offsets.push_back(options_.rotation_guess_rad);
  }
  return matchFromStarts(reference, normals, current, guess, offsets);
}

ScanMatchResult ScanMatcher::matchFromStarts(const std::vector<Eigen::Vector2d>& reference,
                                             const std::vector<Eigen::Vector2d>& normals,
                                             const std::vector<Eigen::Vector2d>& current,
                                             const Pose2& guess,
                                             const std::vector<double>& offsets) const {
  ScanMatchResult best;
  // Prefer accepted results within the correction bound; keep the best rejected one for
  // diagnostics.
  double best_score = -1e300;
  for (double offset : offsets) {
    Pose2 start = guess;
    start.z() = wrapAngle(start.z() + offset);
    ScanMatchResult r = matchFrom(reference, normals, current, start);
    if (r.ok) {
      const Pose2 correction = between(guess, r.delta);
      r.ok = correction.head<2>().norm() <= options_.max_correction_m &&
             std::fabs(correction.z()) <= options_.max_correction_rad;
    }
    if (score(r) > best_score) {
      best_score = score(r);
      best = r;
    }
  }
  return best;
}

ScanMatchResult ScanMatcher::matchFrom(const std::vector<Eigen::Vector2d>& reference,
                                       const std::vector<Eigen::Vector2d>& normals,
                                       const std::vector<Eigen::Vector2d>& current,
                                       const Pose2& start) const {
  ScanMatchResult result;
  const PointGrid grid(reference, options_.max_correspondence_m);
  Pose2 x = start;
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d h_data = Eigen::Matrix3d::Zero();
  int inliers = 0;
  double sum_sq = 0.0;
  for (int it = 0; it < options_.max_iterations; ++it) {
    const double fraction = options_.max_iterations > 1 ? static_cast<double>(it) / (options_.max_iterations - 1) : 1.0;
    const double radius = options_.max_correspondence_m +
                          (options_.min_correspondence_m - options_.max_correspondence_m) * std::min(1.0, 2.0 * fraction);
    const double c = std::cos(x.z()), s = std::sin(x.z());
    h.setZero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    inliers = 0;
    sum_sq = 0.0;
    for (const Eigen::Vector2d& p : current) {
      const Eigen::Vector2d q(x.x() + c * p.x() - s * p.y(), x.y() + s * p.x() + c * p.y());
      double d2;
      const int j = grid.nearest(q, radius, &d2);
      if (j < 0 || normals[j].isZero()) continue;
      const Eigen::Vector2d& n = normals[j];
      const double residual = n.dot(q - reference[j]);
      const Eigen::Vector2d dq_dtheta(-s * p.x() - c * p.y(), c * p.x() - s * p.y());
      const Eigen::Vector3d jac(n.x(), n.y(), n.dot(dq_dtheta));
      // Huber weight so that a few wrong pairs do not pull the solution.
      const double k = 0.5 * radius;
      const double w = std::fabs(residual) <= k ? 1.0 : k / std::fabs(residual);
      h += w * jac * jac.transpose();
      g += w * jac * residual;
      ++inliers;
      sum_sq += residual * residual;
    }
    if (inliers < 10) return result;
    h_data = h;
    // A weak prior toward the start (odometry): a direction the scan cannot see (along a
    // corridor) stays where odometry put it instead of drifting freely.
    Eigen::Vector3d offset = x - start;
    offset.z() = wrapAngle(offset.z());
    const Eigen::Vector3d prior(options_.prior_weight_xy, options_.prior_weight_xy,
                                options_.prior_weight_theta);
    h += prior.asDiagonal();
    g += prior.cwiseProduct(offset);
    const Eigen::Vector3d step = h.ldlt().solve(-g);
    if (!step.allFinite()) return result;
    x += step;
    x.z() = wrapAngle(x.z());
    result.iterations = it + 1;
    if (fraction >= 0.5 && step.head<2>().norm() < 1e-4 && std::fabs(step.z()) < 1e-5) break;
  }
  result.delta = x;
  result.inlier_ratio = static_cast<double>(inliers) / current.size();
  result.residual_rms_m = std::sqrt(sum_sq / std::max(inliers, 1));
  // Degenerate geometry (a corridor) leaves a translation direction unconstrained: along it
  // keep the odometry's translation instead of wherever the points slid to.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(h_data.topLeftCorner<2, 2>());
  result.weakest_information = eigen.eigenvalues().minCoeff();
  for (int i = 0; i < 2; ++i) {
    if (eigen.eigenvalues()(i) >= options_.min_information) continue;
    const Eigen::Vector2d v = eigen.eigenvectors().col(i);
    result.delta.head<2>() += v * v.dot(start.head<2>() - result.delta.head<2>());
    result.degenerate = true;
  }
  result.ok = result.inlier_ratio >= options_.min_inlier_ratio &&
              result.residual_rms_m <= options_.max_residual_rms_m;
  return result;
}

}  // namespace core
}  // namespace rbpf_slam
