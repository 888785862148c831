#!/usr/bin/env bash
# Regression test of config/landmarks_hinf.yaml on real data (docs/results.md, "Session 18" and
# "Session 19"): H-infinity FastSLAM (unknown association, sampled by likelihood) on every robot
# of the shared UTIAS MRCLAM dataset 6, seeds 1-9 (45 runs, about two minutes), through
# benchmarks/run_mrclam. Fails unless at least 31 runs halve the odometry's ATE, the mean ATE /
# odometry ATE is at most 0.45, at least 18 runs map at most 2 spurious landmarks, there are at
# most 7.5 spurious landmarks per run, at least 16 runs put every matched landmark within 0.3 m
# and at least 9 runs meet those three targets at once. Measured as shipped: 34, 0.37, 21, 6.0,
# 23 and 14 (seeds 10-18: 41, 0.28, 28, 3.1, 27, 19). With the most likely match (--set
# association.sample=false, session 18): 35, 0.39, 16, 6.1, 20 and 12, and it fails on the 18.
# Without the negative evidence (--set existence.visible_range_m=0) it passes: 35, 0.31, 24, 4.8,
# 20 and 17 (before the sampling it failed: 8.2 spurious per run, 7 all three).
# The draw (hinf.proposal_covariance) hardly shows here; hinf_car.sh checks it.
# Extra arguments go to run_mrclam; KEEP_WORK=1 keeps the runs and their logs.
# Prints SKIP and exits 77 (scripts/test.sh: skipped) when the dataset is not there.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
source "$here/lib/shared_data.sh"
source "$here/lib/mrclam.sh"

mrclam_run landmarks_hinf "$@"
/usr/bin/python3 "$here/lib/mrclam_check.py" "$work/results.json" --runs 45 --min-halved 31 \
  --max-mean-ratio 0.45 --min-clean 18 --max-spurious 7.5 --min-within 16 --min-all-three 9 \
  --hint "<= 2 spurious: the most likely landmark of a group taken (association.sample false: 16)" \
  --hint "spurious / all three: copies stay in the maps"
