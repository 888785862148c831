// Sonar lines by a Hough vote over the arcs' tangent lines (Tardos et al. 2002) and sonar
// points by a vote over a position grid with least-squares arc triangulation.

#include "sonar_fitting.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

namespace rbpf_slam {
namespace core {
namespace sonar {
namespace {

constexpr int kMaxCandidates = 40;  // peaks examined per extraction, accepted or not
constexpr int kRefinements = 3;

/// A dense vote accumulator with cells that can be excluded from the peak search.
class Accumulator {
 public:
  explicit Accumulator(size_t cells) : votes_(cells, 0), blocked_(cells, 0) {}
  /// Votes may only go down once peak() has been called.
  void add(size_t cell, int delta) { votes_[cell] += delta; }
  void block(size_t cell) { blocked_[cell] = 1; }
  /// The unblocked cell with the most votes (the lowest index among ties); false when none has
  /// at least min_votes. A lazy max-heap: entries whose count went down are re-queued.
  bool peak(int min_votes, size_t* cell) {
    if (!heap_built_) {
      for (size_t i = 0; i < votes_.size(); ++i) {
        if (votes_[i] >= min_votes) heap_.emplace_back(votes_[i], -static_cast<long>(i));
      }
      std::make_heap(heap_.begin(), heap_.end());
      heap_built_ = true;
    }
    while (!heap_.empty()) {
      std::pop_heap(heap_.begin(), heap_.end());
      const auto top = heap_.back();
      heap_.pop_back();
      const size_t index = static_cast<size_t>(-top.second);
      if (blocked_[index] || votes_[index] < min_votes) continue;
      heap_.emplace_back(votes_[index], top.second);
      std::push_heap(heap_.begin(), heap_.end());
      if (votes_[index] != top.first) continue;  // stale: re-queued with its current count
      *cell = index;
      return true;
    }
    return false;
  }

 private:
  std::vector<int32_t> votes_;
  std::vector<uint8_t> blocked_;
  std::vector<std::pair<int32_t, long>> heap_;
  bool heap_built_ = false;
};

// ---------------------------------------------------------------------------------------------
// Lines. Internally theta is the direction from the sensors towards the wall (the echo's
// reflection direction), so rho - sensor . n(theta) is the echo's range.

struct LineFit {
  double rho = 0.0;
  double theta = 0.0;
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();  // over (rho, theta), echo noise only
  std::vector<int> inliers;
};

/// The echo a wall (rho, theta) returns to a transducer: the perpendicular distance when the
/// normal lies inside the cone, else (a wide cone's off-axis echo, up to max_incidence past the
/// cone's edge) the distance along the edge ray nearest the normal. NaN when the wall cannot
/// echo. Also gives the derivatives of the range over rho and theta.
double expectedRange(const LocalEcho& e, double rho, double theta, double max_incidence,
                     double* d_rho = nullptr, double* d_theta = nullptr) {
  const double off = wrapAngle(theta - e.axis);
  const double incidence = std::max(0.0, std::abs(off) - e.half_cone);
  const double distance = rho - e.sensor.dot(unitVector(theta));
  if (incidence > max_incidence || distance <= 0.0) return std::numeric_limits<double>::quiet_NaN();
  const double c = std::cos(incidence);
  if (d_rho) *d_rho = 1.0 / c;
  if (d_theta) {
    const double d_incidence = incidence > 0.0 ? (off > 0.0 ? 1.0 : -1.0) : 0.0;
    *d_theta = -e.sensor.dot(unitVector(theta + M_PI_2)) / c +
               distance * std::sin(incidence) * d_incidence / (c * c);
  }
  return distance / c;
}

/// Where the echo reflected off the wall: the perpendicular foot, or the edge ray's hit.
Eigen::Vector2d reflectionPoint(const LocalEcho& e, double theta) {
  const double off = wrapAngle(theta - e.axis);
  const double direction =
      std::abs(off) <= e.half_cone ? theta : e.axis + (off > 0.0 ? e.half_cone : -e.half_cone);
  return e.sensor + e.range * unitVector(direction);
}

/// Unused echoes within tolerance_m of the range the wall would return, with the normal at
/// most max_incidence past their cone's edge.
std::vector<int> lineInliers(const std::vector<LocalEcho>& echoes, double rho, double theta,
                             double tolerance_m, double max_incidence) {
  std::vector<int> inliers;
  for (size_t i = 0; i < echoes.size(); ++i) {
    const LocalEcho& e = echoes[i];
    if (e.used) continue;
    const double expected = expectedRange(e, rho, theta, max_incidence);
    if (std::abs(e.range - expected) <= tolerance_m) inliers.push_back(i);
  }
  return inliers;
}

/// Gauss-Newton over (rho, theta) of the squared range residuals; false if singular.
bool refineLine(const SonarExtractorOptions& o, const std::vector<LocalEcho>& echoes,
                double max_incidence, LineFit* fit) {
  const double reach = max_incidence + o.cone_margin_rad + o.hough_theta_step_rad;
  Eigen::Matrix2d information = Eigen::Matrix2d::Zero();
  double squares = 0.0;
  int used = 0;
  for (int iteration = 0; iteration < 6; ++iteration) {
    information.setZero();
    Eigen::Vector2d gradient = Eigen::Vector2d::Zero();
    squares = 0.0;
    used = 0;
    for (int i : fit->inliers) {
      Eigen::Vector2d j;
      const double expected = expectedRange(echoes[i], fit->rho, fit->theta, reach, &j.x(), &j.y());
      if (!std::isfinite(expected)) continue;
      const double residual = echoes[i].range - expected;
      j = -j;
      information += j * j.transpose();
      gradient += j * residual;
      squares += residual * residual;
      ++used;
    }
    if (used < 3 || information.determinant() < 1e-9 * std::max(1.0, information.trace())) {
      return false;
    }
    const Eigen::Vector2d step = -information.ldlt().solve(gradient);
    fit->rho += step.x();
    fit->theta = wrapAngle(fit->theta + step.y());
    if (step.norm() < 1e-6) break;
  }
  // The configured echo noise, or the fit's own scatter when that is larger (a poor model).
  const double dof = std::max(1.0, used - 2.0);
  fit->covariance =
      std::max(o.sigma_range_m * o.sigma_range_m, squares / dof) * information.inverse();
  return fit->covariance.allFinite();
}

/// Every arc votes for the lines tangent to it, in the two nearest rho bins of each theta bin.
class LineVotes {
 public:
  LineVotes(const SonarExtractorOptions& o, const std::vector<LocalEcho>& echoes)
      : options_(o), echoes_(echoes) {
    // Whole bins around the circle: the step actually used is 2 pi / bins (at most the
    // configured one), so that bin k and bin k + bins are the same direction.
    theta_bins_ = static_cast<int>(std::ceil(2.0 * M_PI / o.hough_theta_step_rad));
    theta_step_ = 2.0 * M_PI / theta_bins_;
    double rho_max = 0.0;
    for (const LocalEcho& e : echoes) rho_max = std::max(rho_max, e.sensor.norm() + e.range);
    rho_bins_ = static_cast<int>(std::ceil(rho_max / o.hough_rho_step_m)) + 2;
    accumulator_ = Accumulator(static_cast<size_t>(theta_bins_) * rho_bins_);
    for (size_t i = 0; i < echoes.size(); ++i) vote(i, +1);
  }
  void vote(size_t index, int delta) {
    const LocalEcho& e = echoes_[index];
    const double step = theta_step_;
    const double reach = e.half_cone;
    const int first = static_cast<int>(std::ceil((e.axis - reach + M_PI) / step));
    const int last = static_cast<int>(std::floor((e.axis + reach + M_PI) / step));
    for (int k = first; k <= last; ++k) {
      const double theta = -M_PI + k * step;
      const double rho = e.range + e.sensor.dot(unitVector(theta));
      if (rho < 0.0) continue;
      const double bin = rho / options_.hough_rho_step_m;
      const int lower = static_cast<int>(std::floor(bin));
      const int other = bin - lower < 0.5 ? lower - 1 : lower + 1;
      const int wrapped = ((k % theta_bins_) + theta_bins_) % theta_bins_;
      for (int j : {lower, other}) {
        if (j >= 0 && j < rho_bins_) accumulator_.add(cell(wrapped, j), delta);
      }
    }
  }
  bool peak(int min_votes, double* rho, double* theta, size_t* cell_index) {
    if (!accumulator_.peak(min_votes, cell_index)) return false;
    *theta = wrapAngle(-M_PI + static_cast<double>(*cell_index / rho_bins_) * theta_step_);
    *rho = (static_cast<double>(*cell_index % rho_bins_) + 0.5) * options_.hough_rho_step_m;
    return true;
  }
  void block(size_t cell_index) { accumulator_.block(cell_index); }

 private:
  size_t cell(int k, int j) const { return static_cast<size_t>(k) * rho_bins_ + j; }
  const SonarExtractorOptions& options_;
  const std::vector<LocalEcho>& echoes_;
  int theta_bins_ = 0;
  double theta_step_ = 0.0;
  int rho_bins_ = 0;
  Accumulator accumulator_{0};
};

/// Refines a Hough peak into a fit over strict inliers; false when it does not hold up.
bool fitLineAt(const SonarExtractorOptions& o, const std::vector<LocalEcho>& echoes, double rho,
               double theta, LineFit* fit) {
  fit->rho = rho;
  fit->theta = theta;
  // First gather loosely (the peak is quantised), then tighten around the refined line.
  double tolerance = o.line_inlier_m + o.hough_rho_step_m;
  double margin = o.cone_margin_rad + o.hough_theta_step_rad;
  for (int round = 0; round < kRefinements; ++round) {
    fit->inliers = lineInliers(echoes, fit->rho, fit->theta, tolerance, margin);
    if (static_cast<int>(fit->inliers.size()) < o.min_line_echoes) return false;
    if (!refineLine(o, echoes, 0.0, fit)) return false;
    tolerance = o.line_inlier_m;
    margin = o.cone_margin_rad;
  }
  fit->inliers = lineInliers(echoes, fit->rho, fit->theta, tolerance, margin);
  if (static_cast<int>(fit->inliers.size()) < o.min_line_echoes) return false;
  return std::sqrt(fit->covariance(0, 0)) <= o.max_line_sigma_rho_m &&
         std::sqrt(fit->covariance(1, 1)) <= o.max_line_sigma_theta_rad;
}

/// Echoes whose cone clearly held the line's normal, whose reflection point falls on the
/// observed extent, but that reported something well beyond the line.
int lineContradictions(const SonarExtractorOptions& o, const std::vector<LocalEcho>& echoes,
                       const LineFit& fit, double lo, double hi) {
  const Eigen::Vector2d normal = unitVector(fit.theta);
  const Eigen::Vector2d tangent(-normal.y(), normal.x());
  int count = 0;
  for (const LocalEcho& e : echoes) {
    if (!insideCone(e, fit.theta, -0.3 * e.half_cone)) continue;
    const double along = e.sensor.dot(tangent);
    if (along < lo || along > hi) continue;
    const double distance = fit.rho - e.sensor.dot(normal);
    if (distance > 0.0 &&
        e.range > distance + std::max(3.0 * o.line_inlier_m, 3.0 * o.sigma_range_m)) {
      ++count;
    }
  }
  return count;
}

/// The feature of a fit: normal form, floored covariance, extent of the reflection points.
bool lineFeature(const SonarExtractorOptions& o, const std::vector<LocalEcho>& echoes,
                 const LineFit& fit, LineFeature* line) {
  const Eigen::Vector2d normal = unitVector(fit.theta);
  const Eigen::Vector2d tangent(-normal.y(), normal.x());
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int i : fit.inliers) {
    const double along = reflectionPoint(echoes[i], fit.theta).dot(tangent);
    lo = std::min(lo, along);
    hi = std::max(hi, along);
  }
  if (hi - lo < o.min_line_length_m) return false;
  if (lineContradictions(o, echoes, fit, lo, hi) >
      o.max_contradiction_ratio * static_cast<double>(fit.inliers.size())) {
    return false;
  }
  line->start = fit.rho * normal + lo * tangent;
  line->end = fit.rho * normal + hi * tangent;
  line->covariance = fit.covariance;
  line->covariance(0, 0) =
      std::max(line->covariance(0, 0), o.line_sigma_rho_m * o.line_sigma_rho_m);
  const double theta_floor =
      std::max(o.line_sigma_theta_rad, o.line_theta_per_length_m / std::max(hi - lo, 0.01));
  line->covariance(1, 1) = std::max(line->covariance(1, 1), theta_floor * theta_floor);
  line->rho = fit.rho;
  line->theta = fit.theta;
  if (line->rho < 0.0) {  // the origin lies beyond the wall: flip to rho >= 0
    line->covariance(0, 1) = line->covariance(1, 0) = -line->covariance(0, 1);
  }
  normalizeLine(line->rho, line->theta);
  return true;
}

// ---------------------------------------------------------------------------------------------
// Points.

struct PointFit {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  std::vector<int> inliers;
};

std::vector<int> pointInliers(const std::vector<LocalEcho>& echoes, const Eigen::Vector2d& p,
                              double tolerance_m, double cone_margin) {
  std::vector<int> inliers;
  for (size_t i = 0; i < echoes.size(); ++i) {
    const LocalEcho& e = echoes[i];
    if (e.used) continue;
    const Eigen::Vector2d d = p - e.sensor;
    if (std::abs(d.norm() - e.range) > tolerance_m) continue;
    if (insideCone(e, std::atan2(d.y(), d.x()), cone_margin)) inliers.push_back(i);
  }
  return inliers;
}

/// Gauss-Newton over p of sum (|p - s| - range)^2; false when singular.
bool refinePoint(const std::vector<LocalEcho>& echoes, double sigma_m, PointFit* fit) {
  Eigen::Matrix2d information = Eigen::Matrix2d::Zero();
  for (int iteration = 0; iteration < 6; ++iteration) {
    information.setZero();
    Eigen::Vector2d gradient = Eigen::Vector2d::Zero();
    for (int i : fit->inliers) {
      const Eigen::Vector2d d = fit->position - echoes[i].sensor;
      const double distance = d.norm();
      if (distance < 1e-6) return false;
      const Eigen::Vector2d j = d / distance;
      information += j * j.transpose();
      gradient += j * (distance - echoes[i].range);
    }
    if (information.determinant() < 1e-9) return false;
    const Eigen::Vector2d step = -information.ldlt().solve(gradient);
    fit->position += step;
    if (step.norm() < 1e-6) break;
  }
  double squares = 0.0;
  for (int i : fit->inliers) {
    squares += std::pow((fit->position - echoes[i].sensor).norm() - echoes[i].range, 2);
  }
  const double dof = std::max(1.0, static_cast<double>(fit->inliers.size()) - 2.0);
  fit->covariance = std::max(sigma_m * sigma_m, squares / dof) * information.inverse();
  return fit->covariance.allFinite();
}

/// Echoes whose cone clearly held p but that reported something well beyond it.
int contradictions(const SonarExtractorOptions& o, const std::vector<LocalEcho>& echoes,
                   const Eigen::Vector2d& p) {
  int count = 0;
  for (const LocalEcho& e : echoes) {
    const Eigen::Vector2d d = p - e.sensor;
    const double distance = d.norm();
    if (!insideCone(e, std::atan2(d.y(), d.x()), -0.3 * e.half_cone)) continue;
    if (e.range > distance + std::max(3.0 * o.point_inlier_m, 3.0 * o.sigma_range_m)) ++count;
  }
  return count;
}

double sensorBaseline(const std::vector<LocalEcho>& echoes, const std::vector<int>& inliers) {
  double baseline = 0.0;
  for (size_t a = 0; a < inliers.size(); ++a) {
    for (size_t b = a + 1; b < inliers.size(); ++b) {
      baseline = std::max(baseline, (echoes[inliers[a]].sensor - echoes[inliers[b]].sensor).norm());
    }
  }
  return baseline;
}

/// Every arc votes once for each grid cell it crosses.
class PointVotes {
 public:
  PointVotes(const SonarExtractorOptions& o, const std::vector<LocalEcho>& echoes)
      : cell_m_(o.point_cell_m), echoes_(echoes) {
    for (const LocalEcho& e : echoes) {
      if (!e.used) half_size_m_ = std::max(half_size_m_, e.sensor.norm() + e.range + cell_m_);
    }
    side_ = static_cast<int>(std::ceil(2.0 * half_size_m_ / cell_m_));
    accumulator_ = Accumulator(static_cast<size_t>(side_) * side_);
    for (size_t i = 0; i < echoes.size(); ++i) {
      if (!echoes[i].used) vote(i, +1);
    }
  }
  void vote(size_t index, int delta) {
    const LocalEcho& e = echoes_[index];
    const int samples = 1 + static_cast<int>(std::ceil(4.0 * e.half_cone * e.range / cell_m_));
    long last = -1;
    for (int k = 0; k <= samples; ++k) {
      const double angle = e.axis - e.half_cone + 2.0 * e.half_cone * k / samples;
      const Eigen::Vector2d p = e.sensor + e.range * unitVector(angle);
      const long c = cell(p);
      if (c < 0 || c == last) continue;
      accumulator_.add(static_cast<size_t>(c), delta);
      last = c;
    }
  }
  bool peak(int min_votes, Eigen::Vector2d* center, size_t* cell_index) {
    if (!accumulator_.peak(min_votes, cell_index)) return false;
    const double x = (static_cast<double>(*cell_index % side_) + 0.5) * cell_m_ - half_size_m_;
    const double y = (static_cast<double>(*cell_index / side_) + 0.5) * cell_m_ - half_size_m_;
    *center = Eigen::Vector2d(x, y);
    return true;
  }
  void block(size_t cell_index) { accumulator_.block(cell_index); }

 private:
  long cell(const Eigen::Vector2d& p) const {
    const int ix = static_cast<int>(std::floor((p.x() + half_size_m_) / cell_m_));
    const int iy = static_cast<int>(std::floor((p.y() + half_size_m_) / cell_m_));
    if (ix < 0 || iy < 0 || ix >= side_ || iy >= side_) return -1;
    return static_cast<long>(iy) * side_ + ix;
  }
  const double cell_m_;
  const std::vector<LocalEcho>& echoes_;
  double half_size_m_ = 0.0;
  int side_ = 0;
  Accumulator accumulator_{0};
};

/// True when most of a point's echoes are as well explained by a wall tangent to their arcs
/// or met along their cone's edge (a wall heard over a short baseline looks like a point),
/// and a few of them met that wall head-on: such points are not emitted.
bool lineExplains(const SonarExtractorOptions& o, const std::vector<LocalEcho>& echoes,
                  const PointFit& point) {
  constexpr int kHeadOnEchoes = 2;
  LineFit fit;
  Eigen::Vector2d mean_sensor = Eigen::Vector2d::Zero();
  for (int i : point.inliers) mean_sensor += echoes[i].sensor;
  mean_sensor /= static_cast<double>(point.inliers.size());
  const Eigen::Vector2d d = point.position - mean_sensor;
  fit.theta = std::atan2(d.y(), d.x());
  fit.rho = point.position.dot(unitVector(fit.theta));
  fit.inliers = point.inliers;
  if (!refineLine(o, echoes, o.line_max_incidence_rad, &fit)) return false;
  const std::vector<int> supporting = lineInliers(echoes, fit.rho, fit.theta, o.point_inlier_m,
                                                  o.line_max_incidence_rad + o.cone_margin_rad);
  size_t shared = 0;
  int head_on = 0;
  double line_squares = 0.0, point_squares = 0.0;
  for (int i : point.inliers) {
    const LocalEcho& e = echoes[i];
    point_squares += std::pow((point.position - e.sensor).norm() - e.range, 2);
    if (!std::binary_search(supporting.begin(), supporting.end(), i)) continue;
    ++shared;
    head_on += insideCone(e, fit.theta, o.cone_margin_rad) ? 1 : 0;
    line_squares += std::pow(e.range - expectedRange(e, fit.rho, fit.theta, M_PI_2), 2);
  }
  // Explained: by most of the same echoes, a few head-on, at least as closely.
  return shared >= 0.7 * point.inliers.size() && head_on >= kHeadOnEchoes &&
         line_squares / shared <= point_squares / point.inliers.size();
}

bool fitPointAt(const SonarExtractorOptions& o, const std::vector<LocalEcho>& echoes,
                const Eigen::Vector2d& center, PointFit* fit) {
  fit->position = center;
  double tolerance = o.point_inlier_m + 0.71 * o.point_cell_m;
  for (int round = 0; round < kRefinements; ++round) {
    fit->inliers = pointInliers(echoes, fit->position, tolerance, o.cone_margin_rad);
    if (static_cast<int>(fit->inliers.size()) < o.min_point_echoes) return false;
    if (!refinePoint(echoes, o.sigma_range_m, fit)) return false;
    tolerance = o.point_inlier_m;
  }
  fit->inliers = pointInliers(echoes, fit->position, tolerance, o.cone_margin_rad);
  const int support = static_cast<int>(fit->inliers.size());
  if (support < o.min_point_echoes) return false;
  if (sensorBaseline(echoes, fit->inliers) < o.min_point_baseline_m) return false;
  const double largest =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(fit->covariance, Eigen::EigenvaluesOnly)
          .eigenvalues()
          .maxCoeff();
  if (!(std::sqrt(std::max(largest, 0.0)) <= o.max_point_sigma_m)) return false;
  if (contradictions(o, echoes, fit->position) > o.max_contradiction_ratio * support) return false;
  return !(o.extract_lines && lineExplains(o, echoes, *fit));
}

PointFeature pointFeature(const SonarExtractorOptions& o, const PointFit& fit) {
  const Eigen::Vector2d& p = fit.position;
  const double r2 = std::max(p.squaredNorm(), 1e-12), r = std::sqrt(r2);
  Eigen::Matrix2d j;  // d(range, bearing) / d(x, y)
  j << p.x() / r, p.y() / r, -p.y() / r2, p.x() / r2;
  PointFeature point;
  point.range = r;
  point.bearing = std::atan2(p.y(), p.x());
  point.covariance = j * fit.covariance * j.transpose();
  point.covariance(0, 0) =
      std::max(point.covariance(0, 0), o.point_sigma_range_m * o.point_sigma_range_m);
  point.covariance(1, 1) =
      std::max(point.covariance(1, 1), o.point_sigma_bearing_rad * o.point_sigma_bearing_rad);
  return point;
}

/// True when most of a line's echoes are as well explained by one reflecting point (a corner
/// or a post heard over a short baseline): such echoes are left to the point pass.
bool pointExplains(const SonarExtractorOptions& o, const std::vector<LocalEcho>& echoes,
                   const LineFit& line) {
  PointFit fit;
  const Eigen::Vector2d normal = unitVector(line.theta);
  for (int i : line.inliers) fit.position += echoes[i].sensor + echoes[i].range * normal;
  fit.position /= static_cast<double>(line.inliers.size());
  fit.inliers = line.inliers;
  if (!refinePoint(echoes, o.sigma_range_m, &fit)) return false;
  const std::vector<int> supporting =
      pointInliers(echoes, fit.position, o.line_inlier_m, o.cone_margin_rad);
  size_t shared = 0;
  for (int i : line.inliers) {
    shared += std::binary_search(supporting.begin(), supporting.end(), i) ? 1 : 0;
  }
  return shared >= 0.7 * line.inliers.size();
}

}  // namespace

std::vector<LineFeature> extractLines(const SonarExtractorOptions& o,
                                      std::vector<LocalEcho>* echoes) {
  std::vector<LineFeature> lines;
  if (static_cast<int>(echoes->size()) < o.min_line_echoes) return lines;
  LineVotes votes(o, *echoes);
  double rho = 0.0, theta = 0.0;
  size_t cell = 0;
  for (int candidate = 0; candidate < kMaxCandidates; ++candidate) {
    if (!votes.peak(o.min_line_echoes, &rho, &theta, &cell)) break;
    LineFit fit;
    LineFeature line;
    if (!fitLineAt(o, *echoes, rho, theta, &fit) || !lineFeature(o, *echoes, fit, &line) ||
        (o.extract_points && pointExplains(o, *echoes, fit))) {
      votes.block(cell);
      continue;
    }
    lines.push_back(line);
    for (int i : fit.inliers) {
      (*echoes)[i].used = true;
      votes.vote(i, -1);
    }
  }
  return lines;
}

std::vector<PointFeature> extractPoints(const SonarExtractorOptions& o,
                                        std::vector<LocalEcho>* echoes) {
  std::vector<PointFeature> points;
  int unused = 0;
  for (const LocalEcho& e : *echoes) unused += e.used ? 0 : 1;
  if (unused < o.min_point_echoes) return points;
  PointVotes votes(o, *echoes);
  Eigen::Vector2d center;
  size_t cell = 0;
  for (int candidate = 0; candidate < kMaxCandidates; ++candidate) {
    if (!votes.peak(o.min_point_echoes, &center, &cell)) break;
    PointFit fit;
    if (!fitPointAt(o, *echoes, center, &fit)) {
      votes.block(cell);
      continue;
    }
    points.push_back(pointFeature(o, fit));
    for (int i : fit.inliers) {
      (*echoes)[i].used = true;
      votes.vote(i, -1);
    }
  }
  return points;
}

}  // namespace sonar
}  // namespace core
}  // namespace rbpf_slam
