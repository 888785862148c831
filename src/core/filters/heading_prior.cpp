#include "rbpf_slam/core/filters/heading_prior.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {

namespace {

constexpr double kQuarterTurn = M_PI / 2.0;

// A line's weight: its observed length, at least 1 cm so that a line without extent counts.
double lineWeight(const Observation& o) { return std::max(0.01, (o.end - o.start).norm()); }

}  // namespace

void validate(const HeadingPriorOptions& o) {
  requireRange("heading_prior.direction_rad", o.direction_rad, -M_PI, M_PI);
  requireRange("heading_prior.learn_updates", o.learn_updates, 1, 100000);
  requireRange("heading_prior.tolerance_rad", o.tolerance_rad, 1e-4, M_PI / 4.0, false, true);
  requireRange("heading_prior.sigma_rad", o.sigma_rad, 1e-5, 1.0);
  requireRange("heading_prior.min_lines", o.min_lines, 1, 1000);
}

double axisOffset(double angle_rad) {
  double offset = std::fmod(angle_rad + M_PI / 4.0, kQuarterTurn);
  if (offset < 0.0) offset += kQuarterTurn;
  return offset - M_PI / 4.0;
}

HeadingPrior::HeadingPrior(const HeadingPriorOptions& options) : options_(options) { reset(); }

void HeadingPrior::reset() {
  direction_ = options_.learn_direction ? std::numeric_limits<double>::quiet_NaN()
                                        : axisOffset(options_.direction_rad);
  learned_.clear();
  learned_updates_ = 0;
}

void HeadingPrior::learn(const std::vector<Observation>& observations, double heading_rad) {
  if (!options_.enabled || ready() || !std::isfinite(heading_rad)) return;
  const std::size_t before = learned_.size();
  for (const Observation& o : observations) {
    if (o.type != LandmarkType::kLine) continue;
    learned_.emplace_back(axisOffset(o.z.y() + heading_rad), lineWeight(o));
  }
  if (learned_.size() == before || ++learned_updates_ < options_.learn_updates) return;
  // The family: the line whose tolerance window holds the most line length ...
  double best_support = -1.0, centre = 0.0;
  for (const auto& [candidate, unused] : learned_) {
    double support = 0.0;
    for (const auto& [offset, weight] : learned_) {
      if (std::fabs(axisOffset(offset - candidate)) <= options_.tolerance_rad) support += weight;
    }
    if (support > best_support) {
      best_support = support;
      centre = candidate;
    }
  }
  // ... and its weighted mean, taken relative to that line (offsets wrap at +-pi/4).
  double sum = 0.0, weight_sum = 0.0;
  for (const auto& [offset, weight] : learned_) {
    const double relative = axisOffset(offset - centre);
    if (std::fabs(relative) > options_.tolerance_rad) continue;
    sum += weight * relative;
    weight_sum += weight;
  }
  direction_ = axisOffset(centre + sum / weight_sum);
  learned_.clear();
}

bool HeadingPrior::residual(const std::vector<Observation>& observations, double heading_rad,
                            double* offset_rad) const {
  if (!options_.enabled || !ready()) return false;
  double sum = 0.0, weight = 0.0;
  int count = 0;
  for (const Observation& o : observations) {
    if (o.type != LandmarkType::kLine) continue;
    const double offset = axisOffset(o.z.y() + heading_rad - direction_);
    if (!(std::fabs(offset) <= options_.tolerance_rad)) continue;
    sum += lineWeight(o) * offset;
    weight += lineWeight(o);
    ++count;
  }
  if (count < options_.min_lines) return false;
  *offset_rad = sum / weight;
  return true;
}

double HeadingPrior::condition(double offset_rad, Pose2* mean, Eigen::Matrix3d* cov) const {
  // h(x) = heading, z = mean.z() - offset: the innovation is -offset.
  const double s = (*cov)(2, 2) + options_.sigma_rad * options_.sigma_rad;
  const Eigen::Vector3d gain = cov->col(2) / s;
  *mean -= gain * offset_rad;
  mean->z() = wrapAngle(mean->z());
  const Eigen::Matrix3d updated = *cov - gain * cov->row(2);
  *cov = 0.5 * (updated + updated.transpose());
  return -0.5 * (offset_rad * offset_rad / s + std::log(2.0 * M_PI * s));
}

}  // namespace core
}  // namespace rbpf_slam
