#pragma once
// Weight bookkeeping and resampling, as pure functions over weight vectors.

#include <vector>

#include "rbpf_slam/core/random.h"

namespace rbpf_slam {
namespace core {

/// Turns log weights into normalised weights by subtracting the max (log-sum-exp). Returns
/// false, and sets uniform weights, when the log weights are all -inf or contain NaN.
bool normalizeLogWeights(const std::vector<double>& log_weights, std::vector<double>* weights);

/// Neff = 1 / sum(w_i^2) of normalised weights.
double effectiveSampleSize(const std::vector<double>& weights);

/// Low-variance (systematic) resampling: count indices drawn from normalised weights with one
/// uniform offset. Each particle i with weight w_i is drawn floor(count w_i) or one more times.
std::vector<int> resampleLowVariance(const std::vector<double>& weights, int count, Rng& rng);

}  // namespace core
}  // namespace rbpf_slam
