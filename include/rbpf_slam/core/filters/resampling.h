#pragma once
// Weight bookkeeping and resampling, as pure functions over weight vectors.

#include <vector>

#include "rbpf_slam/core/geometry.h"
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

/// KLD-sampling's bound (Fox, "Adapting the sample size in particle filters through
/// KLD-sampling", IJRR 2003, eq. 13; amcl's pf_resample_limit computes the same from two
/// bins on): how many samples keep the Kullback-Leibler divergence between the sample-based
/// and the true posterior below `error` with the probability whose standard normal upper
/// quantile is z, when the samples occupy `bins` bins of the state space. 1 for one bin or none.
int kldSampleBound(int bins, double error, double z);

/// KLD-sampling's options: bins of bin_xy_m x bin_xy_m x bin_theta_rad; between min_count and
/// max_count samples.
struct KldSampling {
  int min_count = 1;
  int max_count = 1;
  double error = 0.01;
  double z = 0.99;  // amcl's kld_z
  double bin_xy_m = 0.5;
  double bin_theta_rad = 0.1745;
};

/// KLD-sampling over low-variance resampling: max_count indices drawn by weight as
/// resampleLowVariance draws them, taken in random order until their count reaches
/// kldSampleBound of the bins their poses occupy (or max_count), and at least min_count. A set
/// gathered in a few bins keeps few samples; one spread over many keeps up to max_count.
/// Unlike amcl (independent draws; all max_count for a cloud in one bin; one more than the
/// bound) this follows Fox: one bin keeps min_count.
std::vector<int> resampleKld(const std::vector<double>& weights, const std::vector<Pose2>& poses,
                             const KldSampling& options, Rng& rng);

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
