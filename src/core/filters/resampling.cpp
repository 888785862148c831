#include "rbpf_slam/core/filters/resampling.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

namespace rbpf_slam {
namespace core {

bool normalizeLogWeights(const std::vector<double>& log_weights, std::vector<double>* weights) {
  weights->assign(log_weights.size(), log_weights.empty() ? 0.0 : 1.0 / log_weights.size());
  double max_log = -std::numeric_limits<double>::infinity();
  for (double lw : log_weights) {
    if (std::isnan(lw)) return false;
    max_log = std::max(max_log, lw);
  }
  if (!std::isfinite(max_log)) return log_weights.empty();
  double sum = 0.0;
  for (size_t i = 0; i < log_weights.size(); ++i) {
    (*weights)[i] = std::exp(log_weights[i] - max_log);
    sum += (*weights)[i];
  }
  for (double& w : *weights) w /= sum;
  return true;
}

double effectiveSampleSize(const std::vector<double>& weights) {
  double sum_sq = 0.0;
  for (double w : weights) sum_sq += w * w;
  return sum_sq > 0.0 ? 1.0 / sum_sq : 0.0;
}

std::vector<int> resampleLowVariance(const std::vector<double>& weights, int count, Rng& rng) {
  std::vector<int> indices;
  if (weights.empty() || count <= 0) return indices;
  indices.reserve(count);
  const double step = 1.0 / count;
  const double start = sampleUniform(rng) * step;
  double cumulative = weights[0];
  size_t i = 0;
  for (int m = 0; m < count; ++m) {
    const double target = start + m * step;
    while (target > cumulative && i + 1 < weights.size()) cumulative += weights[++i];
    indices.push_back(static_cast<int>(i));
  }
  return indices;
}

int kldSampleBound(int bins, double error, double z) {
  if (bins <= 1) return 1;
  // Wilson-Hilferty's approximation of the chi-square quantile with k - 1 degrees of freedom.
  const double k1 = bins - 1;
  const double b = 2.0 / (9.0 * k1);
  const double x = 1.0 - b + std::sqrt(b) * z;
  const double n = std::ceil(k1 / (2.0 * error) * x * x * x);
  return n >= std::numeric_limits<int>::max() ? std::numeric_limits<int>::max()
                                              : static_cast<int>(n);
}

std::vector<int> resampleKld(const std::vector<double>& weights, const std::vector<Pose2>& poses,
                             const KldSampling& options, Rng& rng) {
  std::vector<int> drawn = resampleLowVariance(weights, options.max_count, rng);
  // A random order, so that every prefix is a sample of the whole set (low-variance draws come
  // sorted by index).
  std::shuffle(drawn.begin(), drawn.end(), rng);
  std::unordered_set<long long> bins;
  const auto bin = [&](const Pose2& p) {
    // 21 bits per coordinate: +-1e6 bins, far beyond any map at these sizes.
    const auto index = [](double v, double size) {
      const double i = std::floor(v / size);
      return static_cast<long long>(std::clamp(i, -1048575.0, 1048575.0)) & 0x1FFFFF;
    };
    return (index(p.x(), options.bin_xy_m) << 42) | (index(p.y(), options.bin_xy_m) << 21) |
           index(wrapAngle(p.z()), options.bin_theta_rad);
  };
  size_t count = 0;
  while (count < drawn.size()) {
    const int i = drawn[count++];
    if (i >= 0 && static_cast<size_t>(i) < poses.size() && poses[i].allFinite()) {
      bins.insert(bin(poses[i]));
    }
    if (static_cast<int>(count) >= options.min_count &&
        static_cast<int>(count) >=
            kldSampleBound(static_cast<int>(bins.size()), options.error, options.z)) {
      break;
    }
  }
  drawn.resize(count);
  return drawn;
}

int keptMostProbable(const std::vector<int>& kept, const std::vector<double>& weights) {
  int best = -1;
  for (size_t j = 0; j < kept.size(); ++j) {
    const int i = kept[j];
    if (i < 0 || i >= static_cast<int>(weights.size())) continue;
    if (best < 0 || weights[i] > weights[kept[best]]) best = static_cast<int>(j);
  }
  return best;
}

int mostProbable(const std::vector<double>& weights, int resampled_best) {
  if (weights.empty()) return -1;
  // max_element: the first of equal maxima (minmax_element would give the last).
  const auto highest = std::max_element(weights.begin(), weights.end());
  if (resampled_best >= 0 && resampled_best < static_cast<int>(weights.size()) &&
      *std::min_element(weights.begin(), weights.end()) == *highest) {
    return resampled_best;
  }
  return static_cast<int>(highest - weights.begin());
}

}  // namespace core
}  // namespace rbpf_slam
