#include "rbpf_slam/core/filters/heading_prior.h"

#include <algorithm>
#include <cmath>

#include "rbpf_slam/core/filters/fastslam2.h"
#include "rbpf_slam/core/require_range.h"

namespace rbpf_slam {
namespace core {

namespace {

// A second family holding less than this fraction of the learned length is not trusted: the
// exact perpendicular of the first is assumed instead.
constexpr double kMinSecondFamilyFraction = 0.1;
// A second family learned within this of the first's perpendicular is taken as perpendicular:
// a few scans' lines estimate it less well than the perpendicularity most buildings have
// (ACES, seeds 1-6: 0.30 m learned, 0.23 m perpendicular), while a wall family clearly off it
// (e.g. 85 deg) is kept where it is.
constexpr double kPerpendicularSnapRad = 0.05;
// Learning counts a line towards a family within this (or tolerance_rad if smaller): a wide
// measuring tolerance (sonar) must not let clutter pass for a family.
constexpr double kLearnToleranceRad = 0.1;

// A line's weight: its observed length, at least 1 cm so that a line without extent counts a
// little; 0 (ignored) when non-finite.
double lineWeight(const Observation& o) {
  const double length = (o.end - o.start).norm();
  if (!std::isfinite(length) || !std::isfinite(o.z.y())) return 0.0;
  return std::max(0.01, length);
}

/// The angle wrapped into [-period/2, period/2).
double wrapOffset(double angle_rad, double period) {
  double offset = std::fmod(angle_rad + period / 2.0, period);
  if (offset < 0.0) offset += period;
  return offset - period / 2.0;
}

}  // namespace

void validate(const HeadingPriorOptions& o) {
  requireRange("heading_prior.learn_updates", o.learn_updates, 1, 1000);
  requireRange("heading_prior.min_family_fraction", o.min_family_fraction, 0.0, 1.0);
  requireRange("heading_prior.max_skew_rad", o.max_skew_rad, 0.0, 0.6);
  requireRange("heading_prior.direction_rad", o.direction_rad, -M_PI, M_PI);
  requireRange("heading_prior.tolerance_rad", o.tolerance_rad, 1e-4, M_PI / 4.0, false, true);
  requireRange("heading_prior.sigma_rad", o.sigma_rad, 1e-5, 1.0);
  requireRange("heading_prior.min_lines", o.min_lines, 1, 1000);
  requireRange("heading_prior.outlier_ratio", o.outlier_ratio, 0.0, 1.0, false, true);
  requireRange("heading_prior.drift_per_rad", o.drift_per_rad, 0.0, 10.0);
  requireRange("heading_prior.drift_per_m", o.drift_per_m, 0.0, 10.0);
}

double halfTurnOffset(double angle_rad) { return wrapOffset(angle_rad, M_PI); }

HeadingPrior::HeadingPrior(const HeadingPriorOptions& options) : options_(options) { reset(); }

void HeadingPrior::reset() {
  ready_ = !options_.learn_direction;
  families_ = {halfTurnOffset(options_.direction_rad),
               halfTurnOffset(options_.direction_rad + M_PI / 2.0)};
  learned_.clear();
  learned_updates_ = 0;
  drift_variance_ = 0.0;
}

double HeadingPrior::strongest(const std::vector<std::pair<double, double>>& samples,
                               const double* around, double period, double* direction) const {
  const double tolerance = std::min(options_.tolerance_rad, kLearnToleranceRad);
  double best_support = 0.0, centre = 0.0;
  for (const auto& [candidate, unused] : samples) {
    if (around && std::fabs(wrapOffset(candidate - *around, period)) > options_.max_skew_rad)
      continue;
    double support = 0.0;
    for (const auto& [other, weight] : samples) {
      if (std::fabs(wrapOffset(other - candidate, period)) <= tolerance) support += weight;
    }
    if (support > best_support) {
      best_support = support;
      centre = candidate;
    }
  }
  if (best_support <= 0.0) return 0.0;
  // The family's weighted mean, taken relative to its centre (directions wrap at +-period/2).
  double sum = 0.0, weight_sum = 0.0;
  for (const auto& [other, weight] : samples) {
    const double relative = wrapOffset(other - centre, period);
    if (std::fabs(relative) > tolerance) continue;
    sum += weight * relative;
    weight_sum += weight;
  }
  *direction = wrapOffset(centre + sum / weight_sum, period);
  return best_support;
}

void HeadingPrior::learn(const std::vector<Observation>& observations, double heading_rad,
                         bool conclude) {
  if (!options_.enabled || ready_ || !std::isfinite(heading_rad)) return;
  const std::size_t before = learned_.size();
  for (const Observation& o : observations) {
    if (o.type != LandmarkType::kLine || lineWeight(o) <= 0.0) continue;
    learned_.emplace_back(halfTurnOffset(o.z.y() + heading_rad), lineWeight(o));
  }
  if (learned_.size() == before) return;
  if (++learned_updates_ < options_.learn_updates && !conclude) return;
  double total = 0.0;
  for (const auto& sample : learned_) total += sample.second;
  double first = 0.0, second = 0.0, first_support = 0.0, second_support = 0.0;
  if (options_.max_skew_rad <= 0.0) {
    // Exactly perpendicular families: both learned together, directions modulo a quarter turn.
    first_support = strongest(learned_, nullptr, M_PI / 2.0, &first);
    second = halfTurnOffset(first + M_PI / 2.0);
  } else {
    first_support = strongest(learned_, nullptr, M_PI, &first);
    const double perpendicular = halfTurnOffset(first + M_PI / 2.0);
    second_support = strongest(learned_, &perpendicular, M_PI, &second);
    if (second_support < kMinSecondFamilyFraction * total) {
      second = perpendicular;  // not seen (a corridor): assume the perpendicular
      second_support = 0.0;
    } else if (std::fabs(halfTurnOffset(second - perpendicular)) <= kPerpendicularSnapRad) {
      second = perpendicular;
    }
  }
  const bool found = first_support + second_support >= options_.min_family_fraction * total;
  learned_.clear();
  learned_updates_ = 0;
  if (!found) return;  // clutter, or no dominant walls in view: learn again from the next scans
  families_ = {first, second};
  ready_ = true;
}

int HeadingPrior::familyOf(double direction_rad) const {
  int family = -1;
  double nearest = options_.tolerance_rad;
  for (int f = 0; f < 2; ++f) {
    const double offset = std::fabs(halfTurnOffset(direction_rad - families_[f]));
    if (offset <= nearest) {
      nearest = offset;
      family = f;
    }
  }
  return family;
}

HeadingPrior::LineSelection HeadingPrior::select(const std::vector<Observation>& observations,
                                                 double reference_rad) const {
  LineSelection selection;
  if (!options_.enabled || !ready_ || !std::isfinite(reference_rad)) return selection;
  for (const Observation& o : observations) {
    if (o.type != LandmarkType::kLine || lineWeight(o) <= 0.0) continue;
    const int family = familyOf(o.z.y() + reference_rad);
    if (family >= 0) selection.lines.push_back({o.z.y(), families_[family], lineWeight(o)});
  }
  return selection;
}

bool HeadingPrior::residual(const LineSelection& selection, double heading_rad,
                            double* offset_rad) const {
  if (!std::isfinite(heading_rad) ||
      static_cast<int>(selection.lines.size()) < options_.min_lines) {
    return false;
  }
  double sum = 0.0, weight = 0.0;
  for (const LineSelection::Line& l : selection.lines) {
    sum += l.weight * halfTurnOffset(l.observed_rad + heading_rad - l.family_rad);
    weight += l.weight;
  }
  *offset_rad = sum / weight;
  return true;
}

bool HeadingPrior::residual(const std::vector<Observation>& observations, double reference_rad,
                            double heading_rad, double* offset_rad) const {
  return residual(select(observations, reference_rad), heading_rad, offset_rad);
}

double HeadingPrior::inlierProbability(double offset_rad, double s, double* log_likelihood) const {
  const double log_inlier = -0.5 * (offset_rad * offset_rad / s + std::log(2.0 * M_PI * s));
  if (options_.outlier_ratio <= 0.0) {
    *log_likelihood = log_inlier;
    return 1.0;
  }
  // A wrong line (clutter, a badly fitted wall) is as likely anywhere within the tolerance.
  const double log_outlier = std::log(options_.outlier_ratio / (2.0 * options_.tolerance_rad));
  const double log_in = std::log(1.0 - options_.outlier_ratio) + log_inlier;
  const double top = std::max(log_in, log_outlier);
  *log_likelihood = top + std::log(std::exp(log_in - top) + std::exp(log_outlier - top));
  return std::exp(log_in - *log_likelihood);
}

namespace {

/// A scalar measurement of the state's last component (the heading) with innovation -offset and
/// innovation variance s: the Kalman step weighted by the probability that the measurement is
/// right, and the mixture's spread (moment matching; exactly the Kalman step when inlier is 1).
template <int N>
void weightedHeadingStep(double offset_rad, double s, double inlier,
                         Eigen::Matrix<double, N, 1>* mean, Eigen::Matrix<double, N, N>* cov) {
  const Eigen::Matrix<double, N, 1> gain = cov->col(N - 1) / s;
  const Eigen::Matrix<double, N, 1> shift = gain * offset_rad;
  *mean -= inlier * shift;
  const Eigen::Matrix<double, N, N> updated =
      *cov - inlier * gain * cov->row(N - 1) + inlier * (1.0 - inlier) * shift * shift.transpose();
  *cov = 0.5 * (updated + updated.transpose());
}

}  // namespace

double HeadingPrior::condition(double offset_rad, Pose2* mean, Eigen::Matrix3d* cov) const {
  // h(x) = heading, z = mean.z() - offset: the innovation is -offset.
  const double s = (*cov)(2, 2) + options_.sigma_rad * options_.sigma_rad;
  double log_likelihood = 0.0;
  const double inlier = inlierProbability(offset_rad, s, &log_likelihood);
  weightedHeadingStep<3>(offset_rad, s, inlier, mean, cov);
  mean->z() = wrapAngle(mean->z());
  return log_likelihood;
}

void HeadingPrior::predictDrift(double rotation_rad, double translation_m) {
  if (!std::isfinite(rotation_rad) || !std::isfinite(translation_m)) return;
  drift_variance_ += options_.drift_per_rad * options_.drift_per_rad * std::fabs(rotation_rad) +
                     options_.drift_per_m * options_.drift_per_m * std::fabs(translation_m);
}

double HeadingPrior::correctDrift(const std::vector<Observation>& observations,
                                  double reference_rad) {
  double offset = 0.0;
  if (!residual(observations, reference_rad, reference_rad, &offset)) return 0.0;
  // The drift is the state (mean 0 before the step); the innovation is -offset, as condition().
  const double s = drift_variance_ + options_.sigma_rad * options_.sigma_rad;
  double unused = 0.0;
  const double inlier = inlierProbability(offset, s, &unused);
  Eigen::Matrix<double, 1, 1> correction = Eigen::Matrix<double, 1, 1>::Zero();
  Eigen::Matrix<double, 1, 1> variance = Eigen::Matrix<double, 1, 1>::Constant(drift_variance_);
  weightedHeadingStep<1>(offset, s, inlier, &correction, &variance);
  drift_variance_ = variance(0, 0);
  return correction(0);
}

}  // namespace core
}  // namespace rbpf_slam
