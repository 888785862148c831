#pragma once
// An ensemble of independent filters run side by side on the same input (ensemble.members > 1).
//
// A particle filter that settles on a wrong hypothesis (a heading off by tens of degrees while
// no landmark is in view, then a map built under it) cannot recover once the right particles
// are resampled away; which runs do so depends on the random draws. Independent filters with
// their own seeds fail independently, and the data tell them apart. The ensemble reports one
// member (its estimate, map, particles and path), by ensemble.rank_by: the largest marginal
// likelihood p(z_1:t) each FastSLAM filter estimates from its weights (UpdateStats::
// log_evidence), the fewest landmarks created (sightings the member's map did not explain), or
// the best path closest to the other members' (consensus, every consensus_period updates).
// After a run the smoother ranks the members again on the whole run (map_smoother.h).
// Costs members x one filter's time and memory.

#include <memory>
#include <vector>

#include "rbpf_slam/core/filters/slam_filter.h"

namespace rbpf_slam {
namespace core {

/// The seed of member k: options.seed for member 0 (an ensemble of one is the plain filter),
/// well-mixed distinct seeds for the others (so that neighbouring run seeds share no member).
unsigned long ensembleMemberSeed(unsigned long seed, int k);

/// The member rank_by consensus reports, given each member's best path as
/// SlamFilter::bestPathSample gives it (evenly spaced poses) with its whole length: the one
/// whose path has the smallest median distance to the others' (RMS after rigid alignment), if
/// shorter than the leader's by more than margin_m. Members left_out (lost) and paths holding
/// a non-finite pose take no part and cannot lead; a leader left out is replaced at once. -1
/// (no choice) with fewer than three paths to compare, or when the whole lengths differ (after
/// a member's reset). Throws std::invalid_argument unless there is one length and one flag per
/// path.
int consensusChoice(const std::vector<std::vector<Pose2>>& paths,
                    const std::vector<size_t>& lengths, const std::vector<bool>& left_out,
                    int leader, double margin_m);
/// A member's running log evidence after one more update's: the sum, or -inf (a lost member,
/// which never leads again, by any rank_by) once an update's evidence is not finite (NaN, or
/// +-inf from a collapsed covariance). Never NaN, so the ranking stays a strict order.
double addLogEvidence(double total, double update_log_evidence);

/// options.ensemble.members filters of options.variant; throws std::invalid_argument naming the
/// first bad option (as createFilter, which calls this when members > 1).
std::unique_ptr<SlamFilter> createEnsembleFilter(const FilterOptions& options);

}  // namespace core
}  // namespace rbpf_slam
