#pragma once
// Line and point features from one 2D laser scan (Yuen & MacDonald incremental
// least squares, or split-and-merge), fitted in (rho, theta) with propagated covariance.

#include <string>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"

namespace rbpf_slam {
namespace core {

struct LaserExtractorOptions {
  std::string method = "incremental";   // incremental | split_and_merge
  double sigma_range_m = 0.02;          // range noise used to propagate the line covariance
  double max_mean_sq_residual_m2 = 0.0004;  // incremental: grow while MSE stays under this
  double split_distance_m = 0.05;       // split_and_merge: split when a point is farther
  double max_point_gap_m = 0.5;         // a larger gap between neighbours breaks a segment
  int min_points_per_line = 6;
  double min_line_length_m = 0.5;
  double merge_angle_rad = 0.05;        // adjacent collinear segments merge below these
  double merge_distance_m = 0.05;
  bool extract_corners = true;
  double corner_min_angle_rad = 0.5;    // two lines meeting at least this sharply
  double corner_max_gap_m = 0.3;        // endpoints this close make a corner
  bool extract_clusters = true;
  double cluster_max_width_m = 0.3;     // posts, legs, trunks: isolated and narrow
  int cluster_min_points = 2;
  double cluster_isolation_m = 0.5;     // depth jump on both sides
  double sigma_point_range_m = 0.05;    // covariance of point features
  double sigma_point_bearing_rad = 0.02;
  double max_range_m = 0.0;             // 0: use the scan's range_max
};

/// Throws std::invalid_argument naming the first out-of-range field.
void validate(const LaserExtractorOptions& options);

/// Extracts line and point features from laser scans; stateless between scans.
class LaserLineExtractor {
 public:
  /// Throws std::invalid_argument (see validate) for out-of-range options.
  explicit LaserLineExtractor(const LaserExtractorOptions& options);
  /// Features in the base frame (the scan's sensor_pose applied); invalid beams skipped.
  FeatureSet extract(const RangeScan& scan) const;
  const LaserExtractorOptions& options() const { return options_; }

 private:
  const LaserExtractorOptions options_;
};

/// Total-least-squares line through points, with the (rho, theta) covariance propagated
/// from isotropic point noise sigma_m. Returns false for fewer than two distinct points.
bool fitLine(const std::vector<Eigen::Vector2d>& points, double sigma_m, LineFeature* line);

/// Running point sums giving an O(1) total-least-squares line fit after each add or remove.
struct LineMoments {
  double n = 0.0;
  double sx = 0.0, sy = 0.0;
  double sxx = 0.0, sxy = 0.0, syy = 0.0;

  void add(const Eigen::Vector2d& p) {
    n += 1.0;
    sx += p.x();
    sy += p.y();
    sxx += p.x() * p.x();
    sxy += p.x() * p.y();
    syy += p.y() * p.y();
  }
  void remove(const Eigen::Vector2d& p) {
    n -= 1.0;
    sx -= p.x();
    sy -= p.y();
    sxx -= p.x() * p.x();
    sxy -= p.x() * p.y();
    syy -= p.y() * p.y();
  }
  LineMoments& operator+=(const LineMoments& o) {
    n += o.n;
    sx += o.sx;
    sy += o.sy;
    sxx += o.sxx;
    sxy += o.sxy;
    syy += o.syy;
    return *this;
  }
  /// Sum of squared orthogonal residuals of the TLS line (the smaller scatter eigenvalue).
  double residualSum() const;
  /// Sum of squared point offsets along the TLS line (the larger scatter eigenvalue).
  double spread() const;
  /// Mean squared orthogonal residual of the TLS line; 0 for fewer than three points.
  double meanSquaredResidual() const { return n > 2.0 ? residualSum() / n : 0.0; }
  /// Unit normal and signed offset (p . normal = offset on the line), without trigonometry;
  /// false when the points do not define a direction.
  bool normal(Eigen::Vector2d* unit_normal, double* offset) const;
  /// Normal-form line with covariance for isotropic point noise sigma_m (start/end untouched).
  bool fit(double sigma_m, LineFeature* line) const;
};

/// A line feature expressed in the parent frame of pose (e.g. sensor to base), with its
/// (rho, theta) covariance mapped by the Jacobian and rho kept >= 0.
LineFeature transformLineFeature(const Pose2& pose, const LineFeature& line);

/// A point feature expressed in the parent frame of pose, as range/bearing from the parent
/// origin, with its covariance mapped by the Jacobian.
PointFeature transformPointFeature(const Pose2& pose, const PointFeature& point);

}  // namespace core
}  // namespace rbpf_slam
