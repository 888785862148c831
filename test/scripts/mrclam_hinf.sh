#!/usr/bin/env bash
# Regression test of config/landmarks_hinf.yaml on real data (docs/results.md, "Session 18",
# "Session 19" and "Session 20"): H-infinity FastSLAM (unknown association, sampled by
# likelihood, copies of a landmark removed) on every robot of the shared UTIAS MRCLAM dataset 6,
# seeds 1-9 (45 runs, about two minutes), through benchmarks/run_mrclam. Fails unless at least
# 35 runs halve the odometry's ATE, the mean ATE / odometry ATE is at most 0.35, at least 24 runs
# map at most 2 spurious landmarks, there are at most 4.5 spurious landmarks per run, at least 16
# runs put every matched landmark within 0.3 m, at least 15 runs meet those three targets at
# once and the final maps hold at most 3 pairs of copies of one landmark. Measured as shipped:
# 39, 0.28, 31, 3.1, 25, 20 and 0 pairs. Without the removal of copies (--set
# existence.merge_chi2=0, session 19): 34, 0.37, 21, 6.0, 23, 14 and 18 pairs, and it fails on
# six. With the most likely match (--set association.sample=false): 34, 0.41, 20, 5.6, 23 and
# 14, and it fails on five. Without the negative evidence (--set existence.visible_range_m=0):
# 37, 0.30, 25, 4.4, 18, 13 and 1 pair, and it fails on the 15.
# The draw (hinf.proposal_covariance) hardly shows here; hinf_car.sh checks it.
# Extra arguments go to run_mrclam; KEEP_WORK=1 keeps the runs and their logs.
# Prints SKIP and exits 77 (scripts/test.sh: skipped) when the dataset is not there.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
source "$here/lib/shared_data.sh"
source "$here/lib/mrclam.sh"

mrclam_run landmarks_hinf "$@"
/usr/bin/python3 "$here/lib/mrclam_check.py" "$work/results.json" --runs 45 --min-halved 35 \
  --max-mean-ratio 0.35 --min-clean 24 --max-spurious 4.5 --min-within 16 --min-all-three 15 \
  --max-copy-pairs 3 \
  --hint "copy pairs / <= 2 spurious: copies next to their landmarks kept (merge_chi2 0: 18, 21)" \
  --hint "<= 2 spurious: the most likely landmark of a group taken (association.sample false: 20)" \
  --hint "all three: copies mapped under a wrong heading stay (no negative evidence: 13)"
