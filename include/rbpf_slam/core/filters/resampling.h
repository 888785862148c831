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

/// The first position in `kept` (indices drawn from a set with these weights) that holds the
/// most probable of the kept particles (-1 only when kept is empty). After resampling every
/// weight is equal: this names the copy of the best particle, for the map and path a filter
/// reports. (When M are kept of M x K candidates the heaviest candidate may not be drawn.)
int keptMostProbable(const std::vector<int>& kept, const std::vector<double>& weights);

/// The index of the most probable particle: the first largest weight, or, while the weights are
/// all equal after a resampling, `resampled_best` (keptMostProbable of that resampling; -1 for
/// none). -1 when there are no weights. Every particle filter's best particle is this.
int mostProbable(const std::vector<double>& weights, int resampled_best);

}  // namespace core
}  // namespace rbpf_slam
