#pragma once
// Line and point features from sparse, wide-beam sonar echoes. One echo only says that a
// reflector lies somewhere on an arc (the cone at the measured range), so echoes are kept
// over a short window of odometry poses and combined: walls are lines tangent to many arcs
// (a Hough vote over (rho, theta) refined by least squares, after Tardos et al. 2002), and
// corners, edges and posts are spots where arcs taken from different poses intersect
// (a vote over a grid of positions refined by least-squares triangulation).

#include <Eigen/Core>
#include <deque>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"

namespace rbpf_slam {
namespace core {

struct SonarExtractorOptions {
  // Which echoes are used.
  double min_range_m = 0.15;         // closer echoes are rejected (transducer ringing)
  double max_range_m = 4.5;          // farther echoes are rejected (0: only the sensor's max)
  double max_range_margin_m = 0.05;  // a reading within this of the sensor's max is "no echo"
  double cone_rad = 0.0;             // cone opening to assume; 0: each reading's field_of_view
  double sigma_range_m = 0.03;       // echo range noise, for the geometric covariances
  bool reject_isolated = true;       // drop echoes unlike both neighbours of their transducer
  double isolated_jump_m = 0.3;      // ... (range jump plus distance moved) beyond this
  // The window of recent echoes, in the odometry frame.
  double window_distance_m = 1.5;   // drop echoes taken more than this much travel ago
  double window_time_s = 20.0;      // ... or longer ago than this
  int max_echoes = 600;             // ... or beyond this many (oldest first)
  double min_echo_spacing_m = 0.0;  // fast rings: skip an echo when its transducer's last kept
                                    // one is closer than this in travel and range (and
                                    // heading within 2 deg); 0: keep every echo
  // When to extract: after this much motion since the last extraction.
  double extract_distance_m = 0.3;
  double extract_angle_rad = 0.3;
  // Lines (walls).
  bool extract_lines = true;
  double hough_rho_step_m = 0.05;
  double hough_theta_step_rad = 0.0349;    // 2 deg
  int min_line_echoes = 6;                 // never a line from fewer echoes
  double min_line_length_m = 0.6;          // reflection points must spread this far along it
  double line_inlier_m = 0.08;             // |range - distance to the line| for an inlier
  double cone_margin_rad = 0.05;           // normal may leave the cone by this much
  double line_max_incidence_rad = 0.44;    // a wall also echoes along the cone's edge when its
                                           // normal is up to this far past it (critical angle,
                                           // 25 deg): point candidates such a wall explains are
                                           // dropped; lines themselves need the normal inside
  double max_line_sigma_rho_m = 0.08;      // reject fits worse determined than this ...
  double max_line_sigma_theta_rad = 0.04;  // ... (too few poses, too short a baseline)
  double line_sigma_rho_m = 0.2;           // covariance floor (Lee, Kim, Chung 2010)
  double line_sigma_theta_rad = 0.0873;    // 5 deg
  double line_theta_per_length_m = 0.0;    // ... and at least this / the line's length, rad:
                                           // the cone model's error, which the echo fit does
                                           // not see, shrinks with the baseline (0: off)
  // Points (corners, edges, posts).
  bool extract_points = true;
  double point_cell_m = 0.1;                // vote grid resolution
  int min_point_echoes = 4;                 // never a point from fewer echoes
  double min_point_baseline_m = 0.2;        // the supporting sensors must spread this far
  double point_inlier_m = 0.06;             // |range - distance to the point| for an inlier
  double max_point_sigma_m = 0.03;          // reject triangulations worse determined than this
  double max_contradiction_ratio = 0.5;     // reject when this many echoes per supporting one
                                            // passed through the point without seeing it
  double point_sigma_range_m = 0.15;        // covariance floor (Lee, Kim, Chung 2010)
  double point_sigma_bearing_rad = 0.0698;  // 4 deg
};

/// Throws std::invalid_argument naming the first out-of-range field ("sonar_features.x = ...").
void validate(const SonarExtractorOptions& options);

/// Counters over the extractor's life (reset() clears them).
struct SonarExtractorStats {
  long readings = 0;
  long echoes = 0;     // accepted into the window
  long no_echo = 0;    // at or beyond the maximum range
  long too_close = 0;  // below the minimum range
  long invalid = 0;    // NaN / inf range or over 100 m, bad cone or mount (over 100 m off)
  long isolated = 0;   // rejected as cross-talk (last extraction)
  long decimated = 0;  // skipped by min_echo_spacing_m
  long extractions = 0;
  long lines = 0;
  long points = 0;
  long clock_jumps = 0;  // stamps that went back over a second: the window was cleared
};

/// One accepted echo, stored in the odometry frame.
struct SonarEcho {
  Eigen::Vector2d sensor = Eigen::Vector2d::Zero();  // transducer position
  double axis = 0.0;                                 // cone axis direction, rad
  double half_cone = 0.0;                            // rad
  double range = 0.0;                                // m
  double stamp = 0.0;
  double travel = 0.0;  // odometry path length at the reading, m
  int transducer = 0;   // index of the mounting pose, in order of first appearance
};

/// Buffers sonar echoes over a short window of motion and extracts lines and points.
class SonarFeatureExtractor {
 public:
  /// Throws std::invalid_argument (see validate) for out-of-range options.
  explicit SonarFeatureExtractor(const SonarExtractorOptions& options);

  /// Adds readings taken with the base at odom_pose (odometry frame); each reading's
  /// sensor_pose is its transducer in the base frame. Returns the number of echoes kept.
  int addReadings(const std::vector<ConeReading>& readings, const Pose2& odom_pose, double stamp);
  /// True when a reading at stamp would clear the window: it is more than a second before the
  /// newest echo (a restarted clock, or a stale reading).
  bool wouldClearWindow(double stamp) const;
  /// True when the base moved or turned enough since the last extraction (or never extracted).
  bool extractionDue(const Pose2& odom_pose) const;
  /// Lines and points from the echoes in the window, in the base frame at odom_pose.
  FeatureSet extract(const Pose2& odom_pose, double stamp);

  const std::deque<SonarEcho>& echoes() const { return echoes_; }
  const SonarExtractorStats& stats() const { return stats_; }
  const SonarExtractorOptions& options() const { return options_; }
  /// Forgets the window, the transducers and the counters.
  void reset();

 private:
  int transducerIndex(const Pose2& mount);
  /// True when echo adds little to its transducer's last kept echo (min_echo_spacing_m).
  bool redundant(const SonarEcho& echo) const;
  void prune(double stamp);
  /// Forgets the echoes and the motion since them (the transducers and counters stay).
  void clearWindow();

  const SonarExtractorOptions options_;
  std::deque<SonarEcho> echoes_;
  std::vector<Pose2> mounts_;
  std::vector<SonarEcho> last_kept_;  // per transducer (range < 0: none yet)
  bool has_pose_ = false;
  Pose2 last_pose_ = Pose2::Zero();  // at the newest stamp seen (a late reading leaves it)
  double last_pose_stamp_ = 0.0;
  double newest_echo_stamp_ = 0.0;  // of the echoes in the window (set with the first)
  double travel_ = 0.0;
  bool has_extracted_ = false;
  Pose2 last_extraction_pose_ = Pose2::Zero();
  SonarExtractorStats stats_;
};

/// Echoes of a RosAria-style point cloud (points in the base frame at the cone axis) as cone
/// readings: each point is given to the transducer whose axis passes within
/// max_axis_offset_m of it (ahead of the transducer). Points no transducer explains are
/// counted in *unmatched.
std::vector<ConeReading> coneReadingsFromCloud(const std::vector<Eigen::Vector2d>& points,
                                               const std::vector<Pose2>& transducers,
                                               double field_of_view_rad, double min_range_m,
                                               double max_range_m, double stamp,
                                               double max_axis_offset_m, int* unmatched);

}  // namespace core
}  // namespace rbpf_slam
