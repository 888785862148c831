// Total-least-squares line fitting in normal form with first-order covariance, and the
// frame changes of line and point features (sensor to base).

#include <algorithm>
#include <cmath>

#include "rbpf_slam/core/features/laser_line_extractor.h"

namespace rbpf_slam {
namespace core {
namespace {

/// Centred scatter matrix [a b; b c] of the moments, and its eigenvalues.
struct Scatter {
  double a = 0.0, b = 0.0, c = 0.0;
  double lambda_min = 0.0, lambda_max = 0.0;
};

Scatter scatterOf(const LineMoments& m) {
  Scatter s;
  if (m.n < 1.0) return s;
  const double mx = m.sx / m.n, my = m.sy / m.n;
  s.a = std::max(0.0, m.sxx - m.sx * mx);
  s.b = m.sxy - m.sx * my;
  s.c = std::max(0.0, m.syy - m.sy * my);
  const double half_trace = 0.5 * (s.a + s.c);
  const double half_diff = 0.5 * (s.a - s.c);
  const double disc = std::sqrt(half_diff * half_diff + s.b * s.b);
  s.lambda_max = half_trace + disc;
  // det / lambda_max is more accurate than half_trace - disc for thin scatters.
  const double det = s.a * s.c - s.b * s.b;
  s.lambda_min = s.lambda_max > 0.0 ? std::max(0.0, det / s.lambda_max) : 0.0;
  return s;
}

}  // namespace

double LineMoments::residualSum() const {
  if (n < 3.0) return 0.0;
  return scatterOf(*this).lambda_min;
}

double LineMoments::spread() const { return scatterOf(*this).lambda_max; }

bool LineMoments::normal(Eigen::Vector2d* unit_normal, double* offset) const {
  if (n < 2.0) return false;
  const Scatter s = scatterOf(*this);
  // The scatter comes from raw sums: identical points leave a rounding residue of about
  // 1e-16 of them, which used to fit an arbitrary direction with a singular covariance of
  // 1e10 (var_theta = sigma^2 / lambda_max). No spread beyond that residue: no line.
  if (!(s.lambda_max > 1e-10 * (sxx + syy))) return false;
  // Eigenvector of lambda_min: rows of (S - lambda_min I) are orthogonal to it, so the
  // normal is perpendicular to the larger row; take the better-conditioned candidate.
  const Eigen::Vector2d v1(s.b, s.lambda_min - s.a);
  const Eigen::Vector2d v2(s.lambda_min - s.c, s.b);
  const Eigen::Vector2d& v = v1.squaredNorm() >= v2.squaredNorm() ? v1 : v2;
  const double norm = v.norm();
  if (!(norm > 0.0)) {
    // Isotropic scatter (a == c, b == 0): every direction fits equally; pick x.
    *unit_normal = Eigen::Vector2d(1.0, 0.0);
  } else {
    *unit_normal = v / norm;
  }
  *offset = (sx * unit_normal->x() + sy * unit_normal->y()) / n;
  return true;
}

bool LineMoments::fit(double sigma_m, LineFeature* line) const {
  Eigen::Vector2d nrm;
  double offset;
  if (!normal(&nrm, &offset)) return false;
  double rho = offset;
  double theta = std::atan2(nrm.y(), nrm.x());
  normalizeLine(rho, theta);
  const Scatter s = scatterOf(*this);
  // First-order propagation of isotropic point noise sigma through the TLS fit: with
  // u_i = p_i . t, t = (-sin theta, cos theta) = d(normal)/d(theta), the perturbations obey
  // w_i = d(rho) - u_i d(theta) in least squares, so cov = sigma^2 (A^T A)^-1 with rows
  // [1, -u_i]: var(theta) = sigma^2 / S, var(rho) = sigma^2 / n + u_mean^2 var(theta),
  // cov(rho, theta) = +u_mean var(theta), where S = sum (u_i - u_mean)^2 = lambda_max.
  const double var_theta = sigma_m * sigma_m / s.lambda_max;
  const double u_mean = (-std::sin(theta) * sx + std::cos(theta) * sy) / n;
  line->rho = rho;
  line->theta = theta;
  line->covariance << sigma_m * sigma_m / n + u_mean * u_mean * var_theta, u_mean * var_theta,
      u_mean * var_theta, var_theta;
  return true;
}

bool fitLine(const std::vector<Eigen::Vector2d>& points, double sigma_m, LineFeature* line) {
  if (points.size() < 2 || line == nullptr) return false;
  // Fit about the first point so that coordinates far from the origin lose no precision.
  const Eigen::Vector2d origin = points.front();
  LineMoments moments;
  for (const Eigen::Vector2d& p : points) moments.add(p - origin);
  LineFeature local;
  if (!moments.fit(sigma_m, &local)) return false;
  const Eigen::Vector2d n(std::cos(local.theta), std::sin(local.theta));
  const Eigen::Vector2d first = points.front() - origin, last = points.back() - origin;
  local.start = first - (first.dot(n) - local.rho) * n;
  local.end = last - (last.dot(n) - local.rho) * n;
  *line = transformLineFeature(Pose2(origin.x(), origin.y(), 0.0), local);
  return true;
}

LineFeature transformLineFeature(const Pose2& pose, const LineFeature& line) {
  LineFeature out;
  double theta = line.theta + pose.z();
  const double c = std::cos(theta), s = std::sin(theta);
  double rho = line.rho + pose.x() * c + pose.y() * s;
  // d(rho_b, theta_b) / d(rho_s, theta_s).
  Eigen::Matrix2d jacobian;
  jacobian << 1.0, -pose.x() * s + pose.y() * c, 0.0, 1.0;
  if (rho < 0.0) {
    rho = -rho;
    theta += M_PI;
    jacobian.row(0) *= -1.0;
  }
  out.rho = rho;
  out.theta = wrapAngle(theta);
  out.covariance = jacobian * line.covariance * jacobian.transpose();
  out.start = transformPoint(pose, line.start);
  out.end = transformPoint(pose, line.end);
  return out;
}

PointFeature transformPointFeature(const Pose2& pose, const PointFeature& point) {
  const double cb = std::cos(point.bearing), sb = std::sin(point.bearing);
  const Eigen::Vector2d local(point.range * cb, point.range * sb);
  const Eigen::Vector2d p = transformPoint(pose, local);
  PointFeature out = point;
  out.range = p.norm();
  out.bearing = std::atan2(p.y(), p.x());
  if (!(out.range > 0.0)) return out;  // at the parent origin: bearing undefined
  Eigen::Matrix2d polar_to_local;      // d(x_s, y_s) / d(range_s, bearing_s)
  polar_to_local << cb, -point.range * sb, sb, point.range * cb;
  const double cp = std::cos(pose.z()), sp = std::sin(pose.z());
  Eigen::Matrix2d rotation;
  rotation << cp, -sp, sp, cp;
  const double r2 = out.range * out.range;
  Eigen::Matrix2d parent_to_polar;  // d(range_b, bearing_b) / d(x_b, y_b)
  parent_to_polar << p.x() / out.range, p.y() / out.range, -p.y() / r2, p.x() / r2;
  const Eigen::Matrix2d jacobian = parent_to_polar * rotation * polar_to_local;
  out.covariance = jacobian * point.covariance * jacobian.transpose();
  return out;
}

}  // namespace core
}  // namespace rbpf_slam
