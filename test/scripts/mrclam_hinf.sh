#!/usr/bin/env bash
# Regression test of config/landmarks_hinf.yaml on real data (docs/results.md, "Session 18" to
# "Session 21"): H-infinity FastSLAM (unknown association, sampled by likelihood, copies of a
# landmark removed, negative evidence out to 5 m with a sighting worth two misses) on every robot
# of the shared UTIAS MRCLAM dataset 6, seeds 1-9 (45 runs, about seven minutes on two cores
# with the ensemble of four), through
# benchmarks/run_mrclam. Fails unless at least 34 runs halve the odometry's ATE, the mean ATE /
# odometry ATE is at most 0.38, at least 29 runs map at most 2 spurious landmarks, there are at
# most 3.0 spurious landmarks per run, at least 23 runs put every matched landmark within 0.3 m,
# at least 21 runs meet those three targets at once and the final maps hold at most 3 pairs of
# copies of one landmark. Measured as shipped: 37, 0.33, 33, 2.6, 27, 23 and 0 pairs. With
# session 20's negative evidence (--set existence.visible_range_m=3.0 --set
# existence.sighting_count=1): 39, 0.28, 31, 3.1, 25, 20 and 0, and it fails on two. Without the
# removal of copies (--set existence.merge_chi2=0): 38, 0.33, 32, 2.9, 27, 22 and 17 pairs, and
# it fails on the pairs. With the most likely match (--set association.sample=false): 37, 0.37,
# 21, 3.8, 27 and 15, and it fails on three. Without the negative evidence (--set
# existence.visible_range_m=0): 37, 0.30, 25, 4.4, 18, 13 and 0 pairs, and it fails on four.
# The draw (hinf.proposal_covariance) hardly shows here; hinf_car.sh checks it.
# The config runs an ensemble of four filters (session 25): "the filter's own" is then the
# member reported while running (the largest marginal likelihood, changed only past a margin of
# 20 nats since session 26), and those limits apply to its path and map (run_mrclam's "filter"
# record). Measured: 40, 0.26, 35, 2.3, 28, 26, 0 and 9 close pairs (the same without the
# margin). The config smooths after the run (session 24), each member, keeping the one whose
# map leaves the fewest sightings outside every gate plus 150 per landmark (session 26) and,
# since session 30, of the members within 150 of that best score the one whose smoothed path the
# others agree with (smoothing.member_consensus_margin 150); the smoothed path and map must
# meet: at least 37 runs halved, mean ratio at most 0.22, at least 35 clean, at most 1.0
# spurious per run, at least 39 within, at least 34 all three, at most 3 copy pairs and 18 close
# pairs (the smoothed covariances, given the path, are tighter, so close pairs are fewer by
# construction). Until session 30 the limits were 0.30, 2.1 and 36 for the mean ratio, the
# spurious landmarks and within. Measured: 44, 0.14, 44, 0.16, 43, 41, 0 and 0; with
# --set smoothing.member_consensus_margin=0 (sessions 26-29): 44, 0.16, 44, 0.31, 41, 41, 0 and
# 0, which passes too (without the landmark cost, session 25: 40, 0.25, 38, 1.7, 39, 37). One
# filter smoothed (--set ensemble.members=1, session 24's figures: 39, 0.25, 36, 1.5, 38, 31, 0
# and 0) fails on four (mean ratio, spurious, within, all three); without smoothing (--set
# smoothing.enabled=false) the second check meets the reported member's figures above and fails
# on four as well (mean ratio, spurious, within, all three; counted from those figures, not
# rerun), and the first finds no "filter" record.
# Extra arguments go to run_mrclam; KEEP_WORK=1 keeps the runs and their logs.
# Prints SKIP and exits 77 (scripts/test.sh: skipped) when the dataset is not there.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
source "$here/lib/shared_data.sh"
source "$here/lib/mrclam.sh"

mrclam_run landmarks_hinf "$@"
status=0
/usr/bin/python3 "$here/lib/mrclam_check.py" "$work/results.json" --runs 45 --filter --min-halved 34 \
  --max-mean-ratio 0.38 --min-clean 29 --max-spurious 3.0 --min-within 23 --min-all-three 21 \
  --max-copy-pairs 3 --max-close-pairs 18 \
  --hint "copy pairs: copies next to their landmarks kept (merge_chi2 0: 17 pairs)" \
  --hint "spurious / all three: session 20's 3 m, one count per sighting (3.1 per run, 20)" \
  --hint "<= 2 spurious: the most likely landmark of a group taken (association.sample false: 21)" \
  --hint "all three: copies mapped under a wrong heading stay (no negative evidence: 13)" || status=1
/usr/bin/python3 "$here/lib/mrclam_check.py" "$work/results.json" --runs 45 --min-halved 37 \
  --max-mean-ratio 0.22 --min-clean 35 --max-spurious 1.0 --min-within 39 --min-all-three 34 \
  --max-copy-pairs 3 --max-close-pairs 18 \
  --hint "all three at one filter's level (31): the ensemble did not run (ensemble.members 1)" \
  --hint "smoothed figures at the filter's own level: the smoothing did not run or undid nothing" \
  || status=1
exit "$status"
