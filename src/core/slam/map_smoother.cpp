#include "rbpf_slam/core/slam/map_smoother.h"

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "rbpf_slam/core/alignment.h"
#include "rbpf_slam/core/filters/measurement_models.h"
#include "rbpf_slam/core/motion/motion_model.h"
#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {

void validate(const SmoothingOptions& o) {
  requireRange("smoothing.rounds", o.rounds, 1, 100);
  requireRange("smoothing.max_iterations", o.max_iterations, 1, 1000);
  requireRange("smoothing.gate_chi2", o.gate_chi2, 0.1, 1000.0);
  requireRange("smoothing.huber_k", o.huber_k, 0.0, 100.0);
  requireRange("smoothing.min_sightings", o.min_sightings, 1, 1000000);
  requireRange("smoothing.member_landmark_cost", o.member_landmark_cost, 0.0, 1e9);
  requireRange("smoothing.member_consensus_margin", o.member_consensus_margin, 0.0, 1e9);
  requireRange("smoothing.merge_max_cost", o.merge_max_cost, 0.0, 1e9);
  requireRange("smoothing.merge_max_distance_m", o.merge_max_distance_m, 0.0, 1e6);
  if (o.merge_max_cost > 0.0 && !(o.merge_max_distance_m > 0.0)) {
    throw std::invalid_argument(
        "smoothing.merge_max_distance_m must be > 0 when smoothing.merge_max_cost > 0 (0 merges "
        "only points at one spot; set merge_max_cost 0 to turn merging off)");
  }
}

namespace {

using Triplets = std::vector<Eigen::Triplet<double>>;

/// A sighting tied to a pose and to a smoothed landmark (its index among the variables).
struct Sighting {
  int pose = 0;
  int landmark = 0;
  Eigen::Vector2d z = Eigen::Vector2d::Zero();
  Eigen::Matrix2d information = Eigen::Matrix2d::Identity();
};

struct Odometry {
  Pose2 delta = Pose2::Zero();
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
};

/// The least-squares problem: poses then smoothed landmarks in one state vector.
class Problem {
 public:
  Problem(int poses, int landmarks, double huber_k) : poses_(poses), landmarks_(landmarks),
                                                      huber_k_(huber_k) {}
  std::vector<Odometry> odometry;  // odometry[i] links pose i and i + 1
  std::vector<Sighting> sightings;
  Pose2 anchor = Pose2::Zero();    // pose 0 is held here

  int size() const { return 3 * poses_ + 2 * landmarks_; }
  Pose2 pose(const Eigen::VectorXd& x, int i) const { return x.segment<3>(3 * i); }
  Eigen::Vector2d landmark(const Eigen::VectorXd& x, int k) const {
    return x.segment<2>(3 * poses_ + 2 * k);
  }

  /// Huber weight of a squared normalised residual.
  double weight(double d2) const {
    if (huber_k_ <= 0.0 || d2 <= huber_k_ * huber_k_) return 1.0;
    return huber_k_ / std::sqrt(d2);
  }
  double robustCost(double d2) const {
    if (huber_k_ <= 0.0 || d2 <= huber_k_ * huber_k_) return d2;
    return 2.0 * huber_k_ * std::sqrt(d2) - huber_k_ * huber_k_;
  }

  double cost(const Eigen::VectorXd& x) const {
    double total = anchorResidual(x).squaredNorm() * kAnchorInformation;
    for (size_t i = 0; i < odometry.size(); ++i) {
      const Pose2 r = odometryResidual(x, static_cast<int>(i));
      total += r.dot(odometry[i].information * r);
    }
    for (const Sighting& s : sightings) {
      const Eigen::Vector2d r = innovation(s.z, predictPoint(pose(x, s.pose),
                                                             landmark(x, s.landmark)).z);
      total += robustCost(r.dot(s.information * r));
    }
    return total;
  }

  /// Gauss-Newton normal equations at x: h (upper and lower) and the gradient g = J^T W r.
  void linearise(const Eigen::VectorXd& x, Eigen::SparseMatrix<double>* h,
                 Eigen::VectorXd* g) const {
    Triplets t;
    t.reserve(9 + odometry.size() * 36 + sightings.size() * 25);
    g->setZero(size());
    const Pose2 r0 = anchorResidual(x);
    for (int k = 0; k < 3; ++k) {
      t.emplace_back(k, k, kAnchorInformation);
      (*g)(k) += kAnchorInformation * r0(k);
    }
    for (size_t i = 0; i < odometry.size(); ++i) {
      const int a = static_cast<int>(i), b = a + 1;
      const Pose2 pa = pose(x, a), pb = pose(x, b);
      const double c = std::cos(pa.z()), s = std::sin(pa.z());
      const Eigen::Vector2d d = pb.head<2>() - pa.head<2>();
      Eigen::Matrix<double, 3, 6> j = Eigen::Matrix<double, 3, 6>::Zero();
      j.block<2, 2>(0, 0) << -c, -s, s, -c;
      j.block<2, 1>(0, 2) << -s * d.x() + c * d.y(), -c * d.x() - s * d.y();
      j.block<2, 2>(0, 3) << c, s, -s, c;
      j(2, 2) = -1.0;
      j(2, 5) = 1.0;
      const Pose2 r = odometryResidual(x, a);
      add(&t, g, {3 * a, 3 * b}, {3, 3}, j, odometry[i].information, r);
    }
    for (const Sighting& s : sightings) {
      const Prediction p = predictPoint(pose(x, s.pose), landmark(x, s.landmark));
      // Residual z - h: its Jacobian is -dh; the sign cancels in J^T W J and flips g.
      const Eigen::Vector2d r = -innovation(s.z, p.z);
      Eigen::Matrix<double, 2, 5> j;
      j << p.h_pose, p.h_landmark;
      const Eigen::Matrix2d w = weight(r.dot(s.information * r)) * s.information;
      add(&t, g, {3 * s.pose, 3 * poses_ + 2 * s.landmark}, {3, 2}, j, w, r);
    }
    h->resize(size(), size());
    h->setFromTriplets(t.begin(), t.end());
  }

 private:
  static constexpr double kAnchorInformation = 1e8;
  int poses_;
  int landmarks_;
  double huber_k_;

  Pose2 anchorResidual(const Eigen::VectorXd& x) const {
    Pose2 r = pose(x, 0) - anchor;
    r.z() = wrapAngle(r.z());
    return r;
  }
  /// between(x_i, x_{i+1}) - delta, with h(x) - measured as the residual's sign.
  Pose2 odometryResidual(const Eigen::VectorXd& x, int i) const {
    const Pose2 b = between(pose(x, i), pose(x, i + 1));
    Pose2 r = b - odometry[i].delta;
    r.z() = wrapAngle(r.z());
    return r;
  }

  /// Adds J^T W J and J^T W r of a factor on two variable blocks (start, size) to t and g.
  template <int Rows, int Cols>
  static void add(Triplets* t, Eigen::VectorXd* g, std::array<int, 2> start,
                  std::array<int, 2> size, const Eigen::Matrix<double, Rows, Cols>& j,
                  const Eigen::Matrix<double, Rows, Rows>& w,
                  const Eigen::Matrix<double, Rows, 1>& r) {
    const Eigen::Matrix<double, Cols, Cols> jtwj = j.transpose() * w * j;
    const Eigen::Matrix<double, Cols, 1> jtwr = j.transpose() * w * r;
    int offset[2] = {0, size[0]};
    for (int u = 0; u < 2; ++u) {
      for (int a = 0; a < size[u]; ++a) {
        (*g)(start[u] + a) += jtwr(offset[u] + a);
        for (int v = 0; v < 2; ++v) {
          for (int b = 0; b < size[v]; ++b) {
            t->emplace_back(start[u] + a, start[v] + b, jtwj(offset[u] + a, offset[v] + b));
          }
        }
      }
    }
  }
};

/// Every point observation to the nearest landmark (Mahalanobis, landmark covariance plus the
/// observation noise) at path, or to the landmark of its known id; -1 when there is none.
std::vector<std::vector<int>> associate(const std::vector<Pose2>& path,
                                        const std::vector<SmoothingFrame>& frames,
                                        const std::vector<LandmarkEstimate>& landmarks,
                                        double gate_chi2) {
  std::vector<std::vector<int>> match(frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    for (const Observation& o : frames[i].observations) {
      int best = -1;
      // A known id: the nearest landmark of that id, however far (the filter keeps copies of
      // an id apart only when they are far apart); else the nearest within the gate.
      const bool known = o.known_id >= 0;
      double best_d2 = known ? std::numeric_limits<double>::infinity() : gate_chi2;
      if (o.type == LandmarkType::kPoint) {
        for (size_t k = 0; k < landmarks.size(); ++k) {
          if (landmarks[k].type != LandmarkType::kPoint) continue;
          if (known && landmarks[k].id != o.known_id) continue;
          const Prediction p = predictPoint(path[i], landmarks[k].mean);
          const Eigen::Matrix2d s =
              landmarkInnovationCovariance(p, landmarks[k].covariance, o.noise);
          const Eigen::Vector2d v = innovation(o.z, p.z);
          const double d2 = v.dot(s.ldlt().solve(v));
          if (std::isfinite(d2) && d2 < best_d2) {
            best_d2 = d2;
            best = static_cast<int>(k);
          }
        }
      }
      match[i].push_back(best);
    }
  }
  return match;
}

bool finiteInput(const std::vector<Pose2>& path, const std::vector<SmoothingFrame>& frames,
                 const std::vector<LandmarkEstimate>& landmarks, std::string* why) {
  for (size_t i = 0; i < path.size(); ++i) {
    const std::string frame = std::to_string(i);
    if (!path[i].allFinite()) return *why = "pose " + frame + " is not finite", false;
    if (!frames[i].motion.allFinite() || !frames[i].motion_covariance.allFinite()) {
      return *why = "the motion of frame " + frame + " is not finite", false;
    }
    for (const Observation& o : frames[i].observations) {
      if (!o.z.allFinite() || !finitePositiveDefinite(o.noise)) {
        return *why = "an observation of frame " + frame +
                      " is not finite or its noise not positive definite", false;
      }
    }
  }
  for (const LandmarkEstimate& l : landmarks) {
    if (!l.mean.allFinite() || !l.covariance.allFinite()) {
      return *why = "landmark " + std::to_string(l.id) + " is not finite", false;
    }
  }
  return true;
}

/// The one-line account of a solution.
std::string describe(const SmoothingResult& r) {
  std::ostringstream text;
  text << r.landmarks_smoothed << " landmarks and " << r.path.size() << " poses from "
       << r.sightings_used << " sightings (" << r.sightings_left_out
       << " outside every gate), cost " << r.initial_cost << " -> " << r.final_cost << " in "
       << r.iterations << " iterations";
  return text.str();
}

/// Solves with a given association (match[i][o]: the landmark of frame i's observation o, or
/// -1), starting at path and the landmarks' means. Input checked by the caller.
SmoothingResult solveWith(const std::vector<Pose2>& path,
                          const std::vector<SmoothingFrame>& frames,
                          const std::vector<LandmarkEstimate>& landmarks,
                          const std::vector<std::vector<int>>& match,
                          const SmoothingOptions& options) {
  SmoothingResult result;
  result.path = path;
  result.landmarks = landmarks;
  // Sightings per landmark; landmarks seen often enough become variables.
  std::vector<int> seen(landmarks.size(), 0);
  for (const auto& frame : match) {
    for (int k : frame) {
      if (k >= 0) ++seen[k];
    }
  }
  std::vector<int> variable(landmarks.size(), -1);
  int smoothed = 0;
  for (size_t k = 0; k < landmarks.size(); ++k) {
    if (seen[k] >= options.min_sightings) variable[k] = smoothed++;
  }
  const int poses = static_cast<int>(path.size());
  Problem problem(poses, smoothed, options.huber_k);
  problem.anchor = path[0];
  for (int i = 1; i < poses; ++i) {
    Eigen::LDLT<Eigen::Matrix3d> ldlt(frames[i].motion_covariance);
    if (ldlt.info() != Eigen::Success || ldlt.vectorD().minCoeff() <= 0.0) {
      result.message = "the motion covariance of frame " + std::to_string(i) +
                       " is not positive definite";
      return result;
    }
    problem.odometry.push_back({frames[i].motion, ldlt.solve(Eigen::Matrix3d::Identity())});
  }
  for (int i = 0; i < poses; ++i) {
    for (size_t o = 0; o < match[i].size(); ++o) {
      const int k = match[i][o];
      if (k < 0) {
        if (frames[i].observations[o].type == LandmarkType::kPoint) ++result.sightings_left_out;
        continue;
      }
      if (variable[k] < 0) continue;
      const Observation& obs = frames[i].observations[o];
      problem.sightings.push_back(
          {i, variable[k], obs.z, obs.noise.ldlt().solve(Eigen::Matrix2d::Identity())});
    }
  }
  result.sightings_used = static_cast<int>(problem.sightings.size());
  if (result.sightings_used == 0) {
    // Odometry alone would only pull the path back to dead reckoning.
    result.message = "no sighting of a landmark seen at least " +
                     std::to_string(options.min_sightings) + " times; nothing to smooth";
    return result;
  }
  result.landmarks_smoothed = smoothed;

  Eigen::VectorXd x(problem.size());
  for (int i = 0; i < poses; ++i) x.segment<3>(3 * i) = path[i];
  for (size_t k = 0; k < landmarks.size(); ++k) {
    if (variable[k] >= 0) x.segment<2>(3 * poses + 2 * variable[k]) = landmarks[k].mean;
  }

  // Levenberg-Marquardt on the sparse normal equations.
  double cost = problem.cost(x);
  result.initial_cost = cost;
  if (!std::isfinite(cost)) {
    result.message = "the cost at the filter's path and map is not finite";
    return result;
  }
  double lambda = 1e-6;
  Eigen::SparseMatrix<double> h;
  Eigen::VectorXd g;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  bool analysed = false;
  for (int it = 0; it < options.max_iterations; ++it) {
    problem.linearise(x, &h, &g);
    if (!analysed) {
      solver.analyzePattern(h);
      analysed = true;
    }
    bool improved = false;
    while (lambda < 1e10) {
      Eigen::SparseMatrix<double> damped = h;
      for (int d = 0; d < damped.rows(); ++d) damped.coeffRef(d, d) *= 1.0 + lambda;
      solver.factorize(damped);
      if (solver.info() != Eigen::Success) {
        lambda *= 10.0;
        continue;
      }
      const Eigen::VectorXd step = solver.solve(-g);
      Eigen::VectorXd trial = x + step;
      for (int i = 0; i < poses; ++i) trial(3 * i + 2) = wrapAngle(trial(3 * i + 2));
      const double trial_cost = problem.cost(trial);
      if (std::isfinite(trial_cost) && trial_cost <= cost) {
        const double decrease = cost - trial_cost;
        x = trial;
        cost = trial_cost;
        lambda = std::max(lambda / 10.0, 1e-9);
        improved = decrease > 1e-9 * std::max(1.0, cost);
        break;
      }
      lambda *= 10.0;
    }
    result.iterations = it + 1;
    if (!improved) break;
  }
  result.final_cost = cost;

  // Landmark covariances given the smoothed path (as FastSLAM's are given a particle's path):
  // the inverse of each landmark's own information block. The marginals would add the
  // uncertainty of the whole map's placement relative to the first pose.
  problem.linearise(x, &h, &g);
  for (int i = 0; i < poses; ++i) result.path[i] = problem.pose(x, i);
  for (size_t k = 0; k < landmarks.size(); ++k) {
    if (variable[k] < 0) continue;
    LandmarkEstimate& l = result.landmarks[k];
    const int at = 3 * poses + 2 * variable[k];
    l.mean = problem.landmark(x, variable[k]);
    const Eigen::Matrix2d information = Eigen::Matrix2d(h.block(at, at, 2, 2));
    Eigen::LDLT<Eigen::Matrix2d> ldlt(information);
    if (ldlt.info() == Eigen::Success && ldlt.vectorD().minCoeff() > 0.0) {
      const Eigen::Matrix2d c = ldlt.solve(Eigen::Matrix2d::Identity());
      l.covariance = 0.5 * (c + c.transpose());
    }
  }
  result.ok = x.allFinite();
  if (!result.ok) {
    result.path = path;
    result.landmarks = landmarks;
    result.message = "the solution is not finite; the filter's path and map are kept";
    return result;
  }
  result.message = describe(result);
  return result;
}

/// One round: associate at path, then solve; *match (if given) receives the association.
SmoothingResult solve(const std::vector<Pose2>& path, const std::vector<SmoothingFrame>& frames,
                      const std::vector<LandmarkEstimate>& landmarks,
                      const SmoothingOptions& options,
                      std::vector<std::vector<int>>* match = nullptr) {
  std::vector<std::vector<int>> m = associate(path, frames, landmarks, options.gate_chi2);
  SmoothingResult result = solveWith(path, frames, landmarks, m, options);
  if (match) *match = std::move(m);
  return result;
}

/// Levenberg-Marquardt iterations at least for each solve of the merge step.
constexpr int kMergeIterations = 100;

/// What the merge step needs to know of each landmark under an association.
struct LandmarkSightings {
  int count = 0;
  int known_id = -1;        // of its sightings (-1: none carries one)
  bool mixed_ids = false;   // its sightings carry different known ids
  std::vector<int> frames;  // frames that sight it, ascending, each once
};

std::vector<LandmarkSightings> sightingsOf(const std::vector<SmoothingFrame>& frames,
                                           const std::vector<std::vector<int>>& match,
                                           size_t landmarks) {
  std::vector<LandmarkSightings> of(landmarks);
  for (size_t i = 0; i < match.size(); ++i) {
    for (size_t o = 0; o < match[i].size(); ++o) {
      const int k = match[i][o];
      if (k < 0) continue;
      LandmarkSightings& l = of[k];
      ++l.count;
      if (l.frames.empty() || l.frames.back() != static_cast<int>(i)) {
        l.frames.push_back(static_cast<int>(i));
      }
      const int id = frames[i].observations[o].known_id;
      if (id >= 0) {
        if (l.known_id >= 0 && l.known_id != id) l.mixed_ids = true;
        l.known_id = id;
      }
    }
  }
  return of;
}

bool sightedTogether(const std::vector<int>& a, const std::vector<int>& b) {
  for (size_t i = 0, j = 0; i < a.size() && j < b.size();) {
    if (a[i] == b[j]) return true;
    if (a[i] < b[j]) ++i; else ++j;
  }
  return false;
}

/// The association with landmark `from`'s sightings given to `into` and `from` removed (the
/// indices above it shift down by one).
std::vector<std::vector<int>> mergedMatch(const std::vector<std::vector<int>>& match, int from,
                                          int into) {
  std::vector<std::vector<int>> merged = match;
  for (auto& frame : merged) {
    for (int& k : frame) {
      if (k == from) k = into;
      if (k > from) --k;
    }
  }
  return merged;
}

/// Merges copies of a landmark in a smoothed result (see SmoothingOptions::merge_max_cost):
/// greedily, the pair whose merge raises the least-squares cost least, while that rise is at
/// most merge_max_cost. `match` is the association `start` was solved with. Returns start
/// unchanged when no pair qualifies; else the result of the last merge, its message (and
/// *merges_text) saying what was merged.
SmoothingResult mergeCopies(const SmoothingResult& start, const std::vector<SmoothingFrame>& frames,
                            std::vector<std::vector<int>> match, SmoothingOptions options,
                            std::string* merges_text) {
  // Costs are compared between solutions: each solve gets iterations enough to converge, and
  // the start is first solved on from where it stopped.
  options.max_iterations = std::max(options.max_iterations, kMergeIterations);
  SmoothingResult current = solveWith(start.path, frames, start.landmarks, match, options);
  if (!current.ok) return start;
  std::ostringstream merged_ids;
  int merges = 0;
  while (true) {
    const std::vector<LandmarkSightings> of = sightingsOf(frames, match, current.landmarks.size());
    const auto usable = [&](size_t k) {
      return current.landmarks[k].type == LandmarkType::kPoint &&
             of[k].count >= options.min_sightings && !of[k].mixed_ids;
    };
    double best_rise = std::numeric_limits<double>::infinity();
    SmoothingResult best;
    std::vector<std::vector<int>> best_match;
    int best_from = -1, best_into = -1;
    for (size_t a = 0; a < current.landmarks.size(); ++a) {
      if (!usable(a)) continue;
      for (size_t b = a + 1; b < current.landmarks.size(); ++b) {
        if (!usable(b) || of[a].known_id != of[b].known_id) continue;
        if ((current.landmarks[a].mean - current.landmarks[b].mean).norm() >
            options.merge_max_distance_m) {
          continue;
        }
        // One frame sights two different landmarks, never one twice.
        if (sightedTogether(of[a].frames, of[b].frames)) continue;
        // The landmark seen more often keeps its id and is the merged one's starting point.
        const bool a_keeps = of[a].count >= of[b].count;
        const int into = static_cast<int>(a_keeps ? a : b), from = static_cast<int>(a_keeps ? b : a);
        std::vector<LandmarkEstimate> landmarks = current.landmarks;
        landmarks[into].observations += landmarks[from].observations;
        landmarks.erase(landmarks.begin() + from);
        std::vector<std::vector<int>> m = mergedMatch(match, from, into);
        SmoothingResult trial = solveWith(current.path, frames, landmarks, m, options);
        if (!trial.ok) continue;
        const double rise = trial.final_cost - current.final_cost;
        if (rise < best_rise) {
          best_rise = rise;
          best = std::move(trial);
          best_match = std::move(m);
          best_from = from;
          best_into = into;
        }
      }
    }
    if (best_from < 0 || !(best_rise <= options.merge_max_cost)) break;
    merged_ids << (merges == 0 ? "" : ", ") << current.landmarks[best_from].id << " into "
               << current.landmarks[best_into].id << " (cost +" << best_rise << ")";
    ++merges;
    current = std::move(best);
    match = std::move(best_match);
  }
  if (merges == 0) return start;
  current.initial_cost = start.initial_cost;
  current.iterations = start.iterations;  // the merge step's solves are not counted
  current.landmarks_merged = merges;
  *merges_text = "; merged " + merged_ids.str();
  current.message = describe(current) + *merges_text;
  return current;
}

}  // namespace

SmoothingResult smoothPathAndMap(const std::vector<Pose2>& path,
                                 const std::vector<SmoothingFrame>& frames,
                                 const std::vector<LandmarkEstimate>& landmarks,
                                 const SmoothingOptions& options) {
  validate(options);
  SmoothingResult result;
  result.path = path;
  result.landmarks = landmarks;
  if (path.size() != frames.size()) {
    result.message = "path and frames differ in length (" + std::to_string(path.size()) +
                     " against " + std::to_string(frames.size()) + ")";
    return result;
  }
  if (path.size() < 2) {
    result.message = "fewer than two poses";
    return result;
  }
  if (!finiteInput(path, frames, landmarks, &result.message)) return result;
  // Each further round associates again at the path and map of the one before.
  std::vector<std::vector<int>> match;
  for (int round = 0; round < options.rounds; ++round) {
    std::vector<std::vector<int>> next_match;
    SmoothingResult next = solve(result.path, frames, result.landmarks, options, &next_match);
    if (!next.ok) {
      if (round == 0) return next;
      break;
    }
    if (round > 0) {
      next.initial_cost = result.initial_cost;
      next.iterations += result.iterations;
    }
    result = next;
    match = std::move(next_match);
  }
  if (!(options.merge_max_cost > 0.0) || match.empty()) return result;
  std::string merges_text;
  SmoothingResult merged = mergeCopies(result, frames, match, options, &merges_text);
  if (merged.landmarks_merged == 0) return result;
  // The merged map associated again at the path it gave: sightings left out before may fall in
  // a gate now. Kept unless it leaves more out (a smaller cost from fewer sightings is no gain).
  SmoothingResult again = solve(merged.path, frames, merged.landmarks, options);
  if (!again.ok || again.sightings_left_out > merged.sightings_left_out) return merged;
  again.initial_cost = result.initial_cost;
  again.iterations += merged.iterations;
  again.landmarks_merged = merged.landmarks_merged;
  again.message = describe(again) + merges_text;
  return again;
}

size_t chooseMember(const std::vector<SmoothingResult>& smoothed, const SmoothingOptions& options,
                    std::string* consensus) {
  if (consensus) consensus->clear();
  if (smoothed.empty()) throw std::invalid_argument("chooseMember needs at least one result");
  const auto score = [&options](const SmoothingResult& r) {
    return r.sightings_left_out + options.member_landmark_cost * r.landmarks_smoothed;
  };
  const auto ranks_before = [&score](const SmoothingResult& a, const SmoothingResult& b) {
    return score(a) < score(b) || (score(a) == score(b) && a.final_cost < b.final_cost);
  };
  size_t chosen = 0;
  for (size_t i = 1; i < smoothed.size(); ++i) {
    if (ranks_before(smoothed[i], smoothed[chosen])) chosen = i;
  }
  if (!(options.member_consensus_margin > 0.0) || smoothed.size() < 3) return chosen;
  // Among the candidates, the path with the smallest median distance to the other members';
  // medians within kSamePath of the smallest count as equal, and the score decides between them
  // (members that found the same path differ by rounding, not by how well they found it).
  constexpr double kSamePath = 1e-3;  // m
  const double limit = score(smoothed[chosen]) + options.member_consensus_margin;
  std::vector<std::vector<Pose2>> paths;
  for (const SmoothingResult& r : smoothed) paths.push_back(r.path);
  const std::vector<double> to_others = medianDistancesToOthers(paths);
  std::vector<std::pair<size_t, double>> medians;  // candidate, its median distance
  for (size_t i = 0; i < smoothed.size(); ++i) {
    if (score(smoothed[i]) <= limit) medians.emplace_back(i, to_others[i]);
  }
  double smallest = std::numeric_limits<double>::infinity();
  for (const auto& m : medians) smallest = std::min(smallest, m.second);
  double chosen_median = smallest;
  bool first = true;
  for (const auto& m : medians) {
    if (m.second > smallest + kSamePath) continue;
    if (first || ranks_before(smoothed[m.first], smoothed[chosen])) {
      chosen = m.first;
      chosen_median = m.second;
      first = false;
    }
  }
  const size_t candidates = medians.size();
  if (consensus) {
    std::ostringstream note;
    note << "the path closest to the others' (median " << chosen_median << " m) of the "
         << candidates << " scoring within " << options.member_consensus_margin
         << " of the best; ";
    *consensus = note.str();
  }
  return chosen;
}

SmoothingResult smoothSession(const SlamSession& session, const FilterOptions& options,
                              const SmoothingOptions& smoothing) {
  const std::vector<SessionFrame>& kept = session.frames();
  SmoothingResult refused;
  refused.path = session.estimatedPath();
  refused.landmarks = session.filter().landmarks();
  if (session.hasPriorMap() || !session.mapping()) {
    // The map frame is the loaded map's, not the first pose's: holding pose 0 would not hold it.
    refused.message = "a prior map was loaded or mapping is off; nothing to smooth";
    return refused;
  }
  if (kept.size() != refused.path.size()) {
    refused.message = kept.empty() ? "the session kept no frames (keep_frames off, or the pose "
                                     "was reset during the run)"
                                   : "the session's frames and path differ in length";
    return refused;
  }
  const std::unique_ptr<MotionModel> model = createMotionModel(options.motion);
  std::vector<SmoothingFrame> frames(kept.size());
  for (size_t i = 0; i < kept.size(); ++i) {
    frames[i].motion = kept[i].motion.delta;
    frames[i].motion_covariance = model->covariance(Pose2::Zero(), kept[i].motion);
    int unusable = 0;  // the filter skipped them too (and counted them)
    frames[i].observations = prepareObservations(kept[i].features, options, &unusable);
  }
  const SlamFilter& filter = session.filter();
  if (filter.members() <= 1) {
    return smoothPathAndMap(refused.path, frames, refused.landmarks, smoothing);
  }
  SmoothingResult leader = refused;
  leader.message = "its path is not one pose per frame";
  std::vector<SmoothingResult> smoothed;  // every member that could be smoothed
  for (int k = 0; k < filter.members(); ++k) {
    const std::vector<Pose2> path = filter.member(k).bestPath();
    if (path.size() != frames.size()) continue;  // not a path per frame: not comparable
    SmoothingResult r = smoothPathAndMap(path, frames, filter.member(k).landmarks(), smoothing);
    r.member = k;
    if (k == filter.leader()) leader = r;
    if (r.ok) smoothed.push_back(std::move(r));
  }
  if (smoothed.empty()) {
    leader.message = "no member of the ensemble could be smoothed; the leader's: " + leader.message;
    return leader;
  }
  std::string consensus;
  SmoothingResult& best = smoothed[chooseMember(smoothed, smoothing, &consensus)];
  std::ostringstream why;
  why << "member " << best.member << " of " << filter.members() << " (the filter's leader "
      << filter.leader() << "; " << consensus << best.sightings_left_out
      << " sightings left out + " << smoothing.member_landmark_cost << " x "
      << best.landmarks_smoothed << " landmarks): " << best.message
      << "; each smoothed member's sightings left out and landmarks:";
  for (size_t i = 0; i < smoothed.size(); ++i) {
    why << (i == 0 ? " " : ", ") << smoothed[i].member << ": " << smoothed[i].sightings_left_out
        << " and " << smoothed[i].landmarks_smoothed;
    if (smoothed[i].landmarks_merged > 0) why << " (" << smoothed[i].landmarks_merged << " merged)";
  }
  best.message = why.str();
  return best;
}

}  // namespace core
}  // namespace rbpf_slam
