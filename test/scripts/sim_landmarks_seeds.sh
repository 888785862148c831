#!/usr/bin/env bash
# The per-update (online) pose of the range-bearing FastSLAM 2.0 config over ten filter seeds on
# the world sim_landmarks.test plays (worlds/test_small.yaml, world seed 7, no roscore):
# sim_landmarks.test decides on one filter seed, and one draw moves the online ATE between
# 0.033 and 0.110 m on this world (docs/results.md, "Session 16"). Fails unless, over filter
# seeds 1-10, the mean online ATE is at most 0.67 x the odometry's and at least 8 of the 10 runs
# are within sim_landmarks.test's 0.75 x the odometry's. Measured (odometry 0.090 m): 500
# particles with sampled association as shipped (session 19), mean 0.050 m (0.55 x), 10 of 10;
# with the most likely match (`--set association.sample=false`) 0.047 m (0.52 x), 10 of 10;
# 100 particles (`--set particles=100` as an argument), mean 0.063 m (0.70 x), 7 of 10, and it
# fails (0.062 m, 0.69 x, 7 of 10 with the most likely match). Since session 25 the config runs
# an ensemble of four filters and the online pose is the leader's: 0.050 m (0.55 x), 9 of 10
# (one filter, `--set ensemble.members=1`: the figures above); since session 27 eight:
# 0.050 m (0.55 x), 10 of 10. With `--set association.ambiguous_weight=soft` (session 33, not
# shipped): 0.066 m (0.73 x), 6 of 10, and it fails; this world is the one where soft loses (on
# world seeds 11 and 13, filter seeds 1-20, it is even with none; docs/results.md, session 34).
# Extra arguments go to each filter run's offline_slam (e.g. --set particles=100 to see it fail).
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam

"$bin/simulate" --world "$root/worlds/test_small.yaml" --output "$work/sim.bag" --seed 7 \
  >"$work/simulate.log" 2>&1 || { echo "FAIL: simulate failed"; cat "$work/simulate.log"; exit 1; }

run() {  # run NAME [offline_slam arguments...]
  local name=$1
  shift
  "$bin/offline_slam" --bag "$work/sim.bag" --config "$root/config/landmarks_fastslam2.yaml" \
    --reference "$work/sim.ref.tum" --output "$work/$name" --no-progress "$@" \
    >"$work/$name.log" 2>&1 || { echo "FAIL: offline_slam ($name) failed"; cat "$work/$name.log"; exit 1; }
}

# Odometry alone: one particle, no motion noise, no landmarks.
run odometry --set particles=1 --set motion.alpha1=0 --set motion.alpha2=0 \
  --set motion.alpha3=0 --set motion.alpha4=0 --set motion.min_sigma_xy_m=0 \
  --set motion.min_sigma_theta_rad=0 --set use_points=false --set use_lines=true \
  --set smoothing.enabled=false
for seed in 1 2 3 4 5 6 7 8 9 10; do
  run "seed$seed" --seed "$seed" "$@"
done

/usr/bin/python3 - "$work" <<'PY'
import json
import math
import sys

work = sys.argv[1]
odometry = json.load(open(work + "/odometry/summary.json"))["ate_online_rmse_m"]
online = [json.load(open("%s/seed%d/summary.json" % (work, s)))["ate_online_rmse_m"]
          for s in range(1, 11)]
if not (math.isfinite(odometry) and odometry > 0 and all(math.isfinite(a) for a in online)):
    sys.exit("FAIL: non-finite ATE: odometry %r, filter %r" % (odometry, online))
mean = sum(online) / len(online)
within = sum(1 for a in online if a <= 0.75 * odometry)
print("online ATE over filter seeds 1-10: %s m" % " ".join("%.3f" % a for a in online))
print("odometry %.3f m; mean %.3f m = %.2f x odometry (at most 0.67); within 0.75 x odometry in "
      "%d of 10 (at least 8)" % (odometry, mean, mean / odometry, within))
if mean > 0.67 * odometry or within < 8:
    sys.exit("FAIL: the online pose is not clearly better than odometry over the seeds")
print("PASS")
PY
