#!/usr/bin/env bash
# Regression test of the landmark configs on real data (docs/results.md, "Session 15: MRCLAM
# heading noise", "Session 16: where the MRCLAM maps go wrong", "Session 17: negative evidence",
# "Session 19: data association sampling", "Session 20: copies of a landmark removed" and
# "Session 21: negative evidence out to 5 m"): FastSLAM 2.0 (config/landmarks_fastslam2.yaml,
# unknown association) on every robot of the shared UTIAS MRCLAM dataset 6, seeds 1-9 (45 runs,
# about 8 minutes with the ensemble of eight on two cores, one run per core), through
# benchmarks/run_mrclam. With the
# rotation noise sized for the commands' real over-rotation the runs no longer lock onto rotated
# headings after turns between sightings, 500 particles keep the right heading hypothesis more
# often, negative evidence in the camera's view (out to 5 m, a sighting worth two misses) removes
# copies of landmarks mapped under a wrong heading, each particle draws its match within a group
# of barcodes by likelihood, and of a copy mapped next to its landmark the less observed one is
# removed. Fails unless the mean ratio of the filter's ATE to the odometry's (both at the update
# stamps) is at most 0.30, the ATE is at most half the odometry's in at least 38 of the 45 runs,
# at least 34 runs map at most 2 spurious landmarks, the mean number of spurious landmarks is at
# most 1.8, at least 28 runs put every matched landmark within 0.3 m, at least 26 runs meet the
# issue's three targets at once (halved, within 0.3 m, <= 2 spurious) and the final maps hold at
# most 3 pairs of copies of one landmark (run_mrclam's copy_pairs); until session 29 the limits
# were 0.42, 33, 28, 3.3, 27 and 21, and the figures that follow were measured against those
# (one filter, sessions 15-21). Measured as shipped then: 0.36, 36,
# 31, 2.7, 32, 24 and 0 pairs. With session 20's negative evidence (--set
# existence.visible_range_m=3.0 --set existence.sighting_count=1): 0.33, 38, 25, 3.8, 29, 20 and
# 0, and it fails on three. Without the removal of copies (--set existence.merge_chi2=0): 0.34,
# 38, 30, 2.5, 30, 23 and 11 pairs, and it fails on the pairs. With the most likely match (--set
# association.sample=false): 0.35, 36, 23, 3.6, 26, 16, and it fails on four. Without the negative
# evidence (--set existence.visible_range_m=0): 0.38, 31, 18, 6.8, 19, 10, and it fails on five.
# Older sessions (before the sampling and the merge): 0.33, 38 and 14 with 100 particles, no
# negative evidence and no sampling; 0.47 and 31 with 100 particles and the noise before (alpha1
# 0.2).
# The means are the sturdier checks; the counts have a margin of 3-5.
# The config runs an ensemble of eight filters (session 27): "the filter's own" is then the
# member reported while running, and those limits apply to its path and map (run_mrclam's
# "filter" record). Since session 29 that member is the one whose best path is closest to the
# other members' (ensemble.rank_by consensus, margin 0.05 m), and the limits are tighter: at least
# 38 halved, mean ratio at most 0.30, at least 34 clean, at most 1.8 spurious per run, at least 28
# within, at least 26 all three. Measured: 43, 0.22, 39, 1.24, 31, 29, 0 and 10. The member of
# the largest marginal likelihood (--set ensemble.rank_by=evidence, the rule of sessions 25-28,
# changed only past 20 nats) gives 39, 0.31, 36, 2.22, 28, 25, 0 and 12 and fails three of them.
# The config smooths after the run (session 24), each member, keeping the one whose map leaves
# the fewest sightings outside every gate plus 150 per landmark (session 26); the smoothed path
# and map must meet tighter limits:
# at least 38 runs halved, mean ratio at most 0.24, at least 36 clean, at most 1.5 spurious per
# run, at least 39 within, at least 34 all three, at most 3 copy pairs and 15 close pairs (the
# smoothed covariances, given the path, are tighter, so close pairs are fewer by construction).
# Measured: 44, 0.15, 40, 0.56, 43, 39, 0 and 0 (session 25's choice without the landmark cost:
# 41, 0.18, 39, 0.82, 43, 38). One filter smoothed (--set ensemble.members=1,
# session 24's figures: 37, 0.28, 35, 2.2, 35, 31, 0 and 2) fails every one of the six; without
# smoothing (--set smoothing.enabled=false) the second check fails as well (and the first finds
# no "filter" record).
# Since session 27 the config runs eight members (the figures above are four's). Measured with
# eight: smoothed 44, 0.14, 44, 0.13, 44, 43, 0 and 0; the leader's own (by evidence) 39, 0.31,
# 36, 2.22, 28, 25, 0 and 12 (within the limits of then; since session 29 see above).
# Session 28 (of the members within 150 of the best score, the one whose path the others agree
# with): smoothed 44, 0.14, 44, 0.13, 45, 44, 0 and 0 (unchanged by session 29's leader).
# Session 33, --set association.ambiguous_weight=soft (a feature between the gate and the
# new-landmark threshold weighs as its landmark or a new one instead of being left out; not
# shipped): smoothed 44, 0.13, 44, 0.16, 44, 43, 0 and 0; the member reported while running 41,
# 0.20, 41, 0.67, 29, 24, 0 and 9, and it fails the all-three limit (24 < 26); on seeds 10-18 its
# reported member meets all three in 30 against 25 (docs/results.md, session 34).
# Extra arguments go to run_mrclam (e.g. --set particles=100 or --set motion.alpha1=0.2 to see
# it fail); KEEP_WORK=1 keeps the runs and their logs.
# Prints SKIP and exits 77 (scripts/test.sh: skipped) when the dataset is not there.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
source "$here/lib/shared_data.sh"
source "$here/lib/mrclam.sh"

mrclam_run landmarks_fastslam2 "$@"
status=0
/usr/bin/python3 "$here/lib/mrclam_check.py" "$work/results.json" --runs 45 --filter --min-halved 38 \
  --max-mean-ratio 0.30 --min-clean 34 --max-spurious 1.8 --min-within 28 --min-all-three 26 \
  --max-copy-pairs 3 --max-close-pairs 15 \
  --hint "the member reported while running chosen by evidence (rank_by evidence: 0.31, 2.22, 25)" \
  --hint "copy pairs: copies next to their landmarks are kept (merge_chi2 0: 11 pairs)" \
  --hint "<= 2 spurious / all three: session 20's 3 m, one count per sighting (25 runs, 20)" \
  --hint "all three: the most likely landmark of a group taken (association.sample false: 16)" \
  --hint "halved / mean ratio: runs lose their heading (session 15's noise before: 31, 0.47)" \
  --hint "spurious / within: copies stay in the maps (no negative evidence: 6.8 per run, 19 within)" || status=1
/usr/bin/python3 "$here/lib/mrclam_check.py" "$work/results.json" --runs 45 --min-halved 38 \
  --max-mean-ratio 0.24 --min-clean 36 --max-spurious 1.5 --min-within 39 --min-all-three 34 \
  --max-copy-pairs 3 --max-close-pairs 15 \
  --hint "smoothed figures of one filter: the ensemble did not run (ensemble.members 1)" \
  --hint "smoothed figures at the filter's own level: the smoothing did not run or undid nothing" \
  || status=1
exit "$status"
