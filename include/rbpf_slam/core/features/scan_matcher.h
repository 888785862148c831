#pragma once
// Point-to-line ICP between consecutive laser scans: turns poor wheel odometry between
// sparse scans into a laser-corrected motion increment for the filter's proposal.

#include <Eigen/Core>
#include <vector>

#include "rbpf_slam/core/features/feature_types.h"

namespace rbpf_slam {
namespace core {

struct ScanMatcherOptions {
  bool enabled = false;
  int max_iterations = 25;
  double max_correspondence_m = 0.5;   // first iterations pair points this far apart ...
  double min_correspondence_m = 0.1;   // ... annealed down to this
  double min_inlier_ratio = 0.4;       // fraction of current points paired at the end
  double max_residual_rms_m = 0.08;    // mean residual of the final pairing
  double max_range_m = 15.0;           // farther returns are too sparse to pair
  double rotation_guess_rad = 0.2;     // also start from odometry rotated by +-this (0: off)
  double search_below_inlier_ratio = 0.0;  // when the best match from those starts pairs fewer
                                       // points than this (or none is accepted), also start
                                       // from every rotation within +-max_correction_rad of
                                       // odometry (0: off) ...
  double search_step_rad = 0.1;        // ... this far apart
  double min_information = 3.0;        // translation information floor; below: that direction
                                       // is degenerate (corridor) and taken from odometry
  double prior_weight_xy = 0.5;        // pull toward the odometry guess, in point-pair units
  double prior_weight_theta = 2.0;
  double max_correction_m = 1.0;       // reject results this far from the odometry ...
  double max_correction_rad = 0.6;     // ... or turned this much from it
  double noise_scale = 0.3;            // motion noise multiplier for matched increments ...
  double degenerate_noise_scale = 1.0;  // ... and for those with a degenerate direction (1:
                                        // odometry's noise, as odometry gave that direction)
  int submap_scans = 1;                // match against the union of this many recent scans
                                       // (chained by their matches); 1 = the last scan only
};

void validate(const ScanMatcherOptions& options);

struct ScanMatchResult {
  bool ok = false;
  Pose2 delta = Pose2::Zero();  // pose of the current scan's base in the reference's base
  double inlier_ratio = 0.0;
  double residual_rms_m = 0.0;
  int iterations = 0;
  double weakest_information = 0.0;  // smallest eigenvalue of the translation information
  bool degenerate = false;  // a translation direction was taken from odometry
  bool from_rest = false;   // matched from zero motion after the odometry start failed (an
                            // odometry glitch); max_correction then bounds the motion itself
};

/// Valid returns of a scan as points in the base frame (sensor pose applied).
std::vector<Eigen::Vector2d> scanPointsInBase(const RangeScan& scan, double max_range_m);

/// Matches scans; stateless, so one matcher serves any number of robots.
class ScanMatcher {
 public:
  explicit ScanMatcher(const ScanMatcherOptions& options);
  /// Aligns current (base frame at t) to reference (base frame at t-1) from initial_delta
  /// (odometry), or, when no match from there is accepted, from zero motion.
  ScanMatchResult match(const std::vector<Eigen::Vector2d>& reference,
                        const std::vector<Eigen::Vector2d>& current,
                        const Pose2& initial_delta) const;
  /// Aligns current to reference from zero motion, for when odometry is not to be trusted (a
  /// glitch): not ok if degenerate (the motion along the weak direction would be the start's
  /// zero, not a measurement); max_correction then bounds the motion itself (from_rest).
  ScanMatchResult matchFromRest(const std::vector<Eigen::Vector2d>& reference,
                                const std::vector<Eigen::Vector2d>& current) const;
  const ScanMatcherOptions& options() const { return options_; }
  /// Motion noise multiplier for an accepted match's increment: degenerate_noise_scale when a
  /// direction was taken from odometry (degenerate), noise_scale otherwise.
  double noiseScale(const ScanMatchResult& result) const;

 private:
  /// The best accepted match from starts at guess turned by each of offsets; not ok if it
  /// ends farther than max_correction from guess.
  ScanMatchResult matchFromStarts(const std::vector<Eigen::Vector2d>& reference,
                                  const std::vector<Eigen::Vector2d>& normals,
                                  const std::vector<Eigen::Vector2d>& current, const Pose2& guess,
                                  const std::vector<double>& offsets) const;
  /// The best of the starts at guess and guess turned by +-rotation_guess_rad; not ok if it
  /// ends farther than max_correction from guess.
  ScanMatchResult matchAround(const std::vector<Eigen::Vector2d>& reference,
                              const std::vector<Eigen::Vector2d>& normals,
                              const std::vector<Eigen::Vector2d>& current,
                              const Pose2& guess) const;
  ScanMatchResult matchFromRest(const std::vector<Eigen::Vector2d>& reference,
                                const std::vector<Eigen::Vector2d>& normals,
                                const std::vector<Eigen::Vector2d>& current) const;
  /// matchAround(guess) and, when that is poor or fails and search_below_inlier_ratio is set,
  /// the fan of rotations within max_correction_rad of guess; the better accepted one.
  ScanMatchResult matchSearching(const std::vector<Eigen::Vector2d>& reference,
                                 const std::vector<Eigen::Vector2d>& normals,
                                 const std::vector<Eigen::Vector2d>& current,
                                 const Pose2& guess) const;
  /// Ranks results: accepted first, then more paired points and a smaller residual.
  static double score(const ScanMatchResult& r);
  ScanMatchResult matchFrom(const std::vector<Eigen::Vector2d>& reference,
                            const std::vector<Eigen::Vector2d>& normals,
                            const std::vector<Eigen::Vector2d>& current, const Pose2& start) const;
  const ScanMatcherOptions options_;
};

}  // namespace core
}  // namespace rbpf_slam
