#include "rbpf_slam/core/filters/relocalization.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/filters/landmark_map.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {
namespace {

constexpr double kHeadingBinRad = 0.5 * M_PI / 180.0;  // heading vote resolution
constexpr int kHeadingPeaks = 2;         // headings tried, best vote counts first
constexpr int kMaxPairConstraints = 40;  // line constraints combined pairwise (bounds the cost)
constexpr double kMinPairSine = 0.5;     // two line constraints fix a position if >= 30 deg apart

/// Direction difference of two line normals modulo pi, in (-pi/2, pi/2].
double wrapHalfTurn(double a) {
  a = wrapAngle(a);
  if (a > M_PI / 2.0) a -= M_PI;
  if (a <= -M_PI / 2.0) a += M_PI;
  return a;
}

/// "The observed feature, moved by translation t, lies on map landmark lm": for a line,
/// n . t = d with n the map line's normal; for a point, t = offset.
struct Constraint {
  int observation = -1;
  bool is_line = true;
  Eigen::Vector2d normal = Eigen::Vector2d::Zero();
  double d = 0.0;
  Eigen::Vector2d offset = Eigen::Vector2d::Zero();  // points
  // Lines: the observed segment along the map line, and the map line's extent.
  double seg_min = 0.0, seg_max = 0.0, extent_min = 0.0, extent_max = 0.0;
};

struct Candidates {
  std::vector<std::vector<int>> lines;   // per observation: map lines near in direction
  std::vector<std::vector<int>> points;  // per observation: map points within reach
};

Candidates findCandidates(const LandmarkMap& map, const Pose2& pose,
                          const std::vector<Observation>& observations,
                          const RelocalizationOptions& o, double margin, int seen_before,
                          std::vector<double>* votes) {
  Candidates c;
  c.lines.resize(observations.size());
  c.points.resize(observations.size());
  const int half = static_cast<int>(std::ceil(o.search_theta_rad / kHeadingBinRad));
  votes->assign(2 * half + 1, 0.0);
  std::vector<int> found;
  for (size_t k = 0; k < observations.size(); ++k) {
    const Observation& obs = observations[k];
    if (obs.known_id >= 0) continue;  // identities known: association needs no search
    if (obs.type == LandmarkType::kLine) {
      LineQuery q;
      q.line = lineFromObservation(pose, obs.z, nullptr);
      q.start = transformPoint(pose, obs.start);
      q.end = transformPoint(pose, obs.end);
      q.max_angle_rad = o.search_theta_rad;
      // Turning about the robot moves a line's rho by up to its distance times the angle.
      q.max_rho_m = o.search_xy_m + obs.z.x() * std::sin(o.search_theta_rad);
      q.overlap_margin_m = margin + o.search_xy_m + 0.5 * (obs.end - obs.start).norm() *
                                                       std::sin(o.search_theta_rad);
      map.lineCandidates(q, &found);
      for (int i : found) {
        const Landmark& lm = map[i];
        if (lm.type != LandmarkType::kLine || lm.last_seen_step >= seen_before) continue;
        const double dtheta = wrapHalfTurn(lm.mean.y() - q.line.y());
        if (std::fabs(dtheta) > o.search_theta_rad) continue;
        c.lines[k].push_back(i);
        const int bin = std::clamp(static_cast<int>(std::lround(dtheta / kHeadingBinRad)) + half,
                                   0, 2 * half);
        (*votes)[bin] += 1.0;  // a vote spread over its neighbours: bins are finer than noise
        if (bin > 0) (*votes)[bin - 1] += 0.5;
        if (bin < 2 * half) (*votes)[bin + 1] += 0.5;
      }
    } else {
      const Eigen::Vector2d p = pointFromObservation(pose, obs.z, nullptr);
      const double reach = o.search_xy_m + obs.z.x() * o.search_theta_rad;
      map.pointCandidates(p, reach, &found);
      for (int i : found) {
        const Landmark& lm = map[i];
        if (lm.type == LandmarkType::kPoint && lm.last_seen_step < seen_before &&
            (lm.mean - p).norm() <= reach) {
          c.points[k].push_back(i);
        }
      }
    }
  }
  return c;
}

/// Up to kHeadingPeaks heading corrections: local maxima of the votes (at least two line
/// pairs agreeing), best first; zero alone when no line pair voted (points only).
std::vector<double> headingPeaks(const std::vector<double>& votes) {
  const int half = static_cast<int>(votes.size() / 2);
  const int bins = static_cast<int>(votes.size());
  bool any_vote = false;
  for (double v : votes) any_vote = any_vote || v > 0.0;
  if (!any_vote) return {0.0};
  std::vector<int> peaks;  // bins that are local maxima with at least two agreeing pairs
  for (int b = 0; b < bins; ++b) {
    const double v = votes[b];
    if (v < 2.0 || (b > 0 && votes[b - 1] > v) || (b + 1 < bins && votes[b + 1] >= v)) continue;
    peaks.push_back(b);
  }
  std::stable_sort(peaks.begin(), peaks.end(), [&](int a, int b) {
    if (votes[a] != votes[b]) return votes[a] > votes[b];  // most votes first ...
    return std::abs(a - half) < std::abs(b - half);         // ... then the smallest turn
  });
  std::vector<double> out;
  for (int b : peaks) {
    const double dtheta = (b - half) * kHeadingBinRad;
    bool near_taken = false;
    for (double t : out) near_taken = near_taken || std::fabs(t - dtheta) < 2.5 * kHeadingBinRad;
    if (!near_taken) out.push_back(dtheta);
    if (static_cast<int>(out.size()) == kHeadingPeaks) break;
  }
  if (out.empty()) out.push_back(0.0);  // no two pairs agree: points at the current heading
  return out;
}

std::vector<Constraint> constraintsAt(const LandmarkMap& map, const Pose2& pose,
                                      const std::vector<Observation>& observations,
                                      const Candidates& candidates,
                                      const RelocalizationOptions& o) {
  std::vector<Constraint> out;
  for (size_t k = 0; k < observations.size(); ++k) {
    const Observation& obs = observations[k];
    if (obs.type == LandmarkType::kLine) {
      const Eigen::Vector2d seen = lineFromObservation(pose, obs.z, nullptr);
      const Eigen::Vector2d a = transformPoint(pose, obs.start), b = transformPoint(pose, obs.end);
      for (int i : candidates.lines[k]) {
        const Landmark& lm = map[i];
        const Eigen::Vector2d diff = lineDifference(seen, lm.mean);  // (drho, dalpha)
        if (std::fabs(diff.y()) > o.angle_tolerance_rad) continue;
        Constraint c;
        c.observation = static_cast<int>(k);
        c.is_line = true;
        c.normal = Eigen::Vector2d(std::cos(lm.mean.y()), std::sin(lm.mean.y()));
        c.d = -diff.x();  // moving the observed line by t changes its rho by n . t
        const double sa = alongLine(lm.mean, a), sb = alongLine(lm.mean, b);
        c.seg_min = std::min(sa, sb);
        c.seg_max = std::max(sa, sb);
        c.extent_min = lm.extent_min;
        c.extent_max = lm.extent_max;
        out.push_back(c);
      }
    } else {
      const Eigen::Vector2d p = pointFromObservation(pose, obs.z, nullptr);
      for (int i : candidates.points[k]) {
        Constraint c;
        c.observation = static_cast<int>(k);
        c.is_line = false;
        c.offset = map[i].mean - p;
        out.push_back(c);
      }
    }
  }
  return out;
}

bool explains(const Constraint& c, const Eigen::Vector2d& t, const RelocalizationOptions& o,
              double margin) {
  if (!c.is_line) return (t - c.offset).norm() <= o.point_tolerance_m;
  if (std::fabs(c.normal.dot(t) - c.d) > o.line_tolerance_m) return false;
  // The moved segment must still meet the map line's extent (collinear walls of other rooms).
  const double shift = -c.normal.y() * t.x() + c.normal.x() * t.y();  // along the line
  const double gap = std::max({c.seg_min + shift - c.extent_max, c.extent_min - (c.seg_max + shift), 0.0});
  return gap <= margin;
}

/// The observations the shift t explains (each once), and in *information (if given) how well
/// they fix t in its least constrained direction: the smallest eigenvalue of the sum of n n^T over
/// the explained lines (n: the wall's normal) and the identity over the explained points.
int support(const std::vector<Constraint>& constraints, const Eigen::Vector2d& t, int observations,
            const RelocalizationOptions& o, double margin, double* information) {
  std::vector<char> explained(observations, 0);
  Eigen::Matrix2d info = Eigen::Matrix2d::Zero();
  int n = 0;
  for (const Constraint& c : constraints) {
    if (explained[c.observation] || !explains(c, t, o, margin)) continue;
    explained[c.observation] = 1;
    if (information) {
      info += c.is_line ? Eigen::Matrix2d(c.normal * c.normal.transpose())
                        : Eigen::Matrix2d::Identity();
    }
    ++n;
  }
  if (information) {
    *information = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(info).eigenvalues()(0);
  }
  return n;
}

}  // namespace

void validate(const RelocalizationOptions& o) {
  requireRange("relocalization.search_xy_m", o.search_xy_m, 0.0, 20.0);
  requireRange("relocalization.search_theta_rad", o.search_theta_rad, 0.0, 1.0);
  requireRange("relocalization.min_unmatched", o.min_unmatched, 1, 1000);
  requireRange("relocalization.min_unmatched_ratio", o.min_unmatched_ratio, 0.0, 1.0);
  requireRange("relocalization.min_matches", o.min_matches, 1, 1000);
  requireRange("relocalization.min_gain", o.min_gain, 1, 1000);
  requireRange("relocalization.min_matched_ratio", o.min_matched_ratio, 0.0, 1.0);
  requireRange("relocalization.min_landmark_age", o.min_landmark_age, 0, 1000000);
  requireRange("relocalization.line_tolerance_m", o.line_tolerance_m, 1e-3, 10.0);
  requireRange("relocalization.angle_tolerance_rad", o.angle_tolerance_rad, 1e-4, 1.0);
  requireRange("relocalization.point_tolerance_m", o.point_tolerance_m, 1e-3, 10.0);
  requireRange("relocalization.min_information", o.min_information, 0.0, 1000.0);
}

PoseCorrection searchPoseCorrection(const LandmarkMap& map, const Pose2& pose,
                                    const std::vector<Observation>& observations,
                                    const RelocalizationOptions& o, double margin,
                                    int seen_before) {
  PoseCorrection best;
  if (observations.empty() || map.size() == 0) return best;
  std::vector<double> votes;
  const Candidates candidates = findCandidates(map, pose, observations, o, margin, seen_before, &votes);
  const int n = static_cast<int>(observations.size());
  double best_cost = INFINITY;  // among equal support: the smallest correction
  for (double dtheta : headingPeaks(votes)) {
    const Pose2 turned(pose.x(), pose.y(), wrapAngle(pose.z() + dtheta));
    const std::vector<Constraint> cs = constraintsAt(map, turned, observations, candidates, o);
    if (cs.empty()) continue;
    std::vector<Eigen::Vector2d> shifts;
    std::vector<int> lines;
    for (int i = 0; i < static_cast<int>(cs.size()); ++i) {
      if (!cs[i].is_line) {
        shifts.push_back(cs[i].offset);
      } else {
        shifts.push_back(cs[i].d * cs[i].normal);  // one wall: the shift along it stays zero
        if (static_cast<int>(lines.size()) < kMaxPairConstraints) lines.push_back(i);
      }
    }
    for (size_t a = 0; a < lines.size(); ++a) {
      for (size_t b = a + 1; b < lines.size(); ++b) {
        const Constraint &ca = cs[lines[a]], &cb = cs[lines[b]];
        if (ca.observation == cb.observation) continue;
        Eigen::Matrix2d m;
        m << ca.normal.transpose(), cb.normal.transpose();
        if (std::fabs(m.determinant()) < kMinPairSine) continue;
        shifts.push_back(m.inverse() * Eigen::Vector2d(ca.d, cb.d));
      }
    }
    for (const Eigen::Vector2d& t : shifts) {
      if (!(t.norm() <= o.search_xy_m)) continue;
      const bool check = o.min_information > 0.0;  // the eigenvalue only when it is asked for
      double information = 0.0;
      const int s = support(cs, t, n, o, margin, check ? &information : nullptr);
      // (less a rounding margin: two points along a slanted corridor give 2 - 1e-16)
      if (check && information < o.min_information - 1e-9) continue;
      const double cost = t.norm() + 10.0 * std::fabs(dtheta);  // 0.1 rad ~ 1 m
      if (s > best.support || (s == best.support && cost < best_cost)) {
        best.support = s;
        best.pose = Pose2(pose.x() + t.x(), pose.y() + t.y(), turned.z());
        best_cost = cost;
      }
    }
  }
  best.found = best.support >= o.min_matches;
  return best;
}

}  // namespace core
}  // namespace rbpf_slam
