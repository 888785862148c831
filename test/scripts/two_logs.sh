#!/usr/bin/env bash
# Two logs in one bag (the second's stamps start over, its bag times follow the first's):
# offline_slam must map the second log with its own odometry. It keeps one tf buffer per run
# (a single buffer drops the second log's transforms, older than the first's, and maps it with
# the first log's odometry: ATE 3.6 m before the fix, 0.04 m after on these worlds), starts a
# new map once, and the trajectory it writes is the second log's.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam

# The second log: test_small (laser and landmark sensor); the first: another world and route
# with the sensor the config uses (laser_office has a laser, lee_sim_b landmarks).
"$bin/simulate" --world "$root/worlds/test_small.yaml" --output "$work/second.bag" --seed 2 \
  --duration 60 >/dev/null
declare -A first_world=([laser_fastslam2]=laser_office [landmarks_fastslam2]=lee_sim_b)
for config in laser_fastslam2 landmarks_fastslam2; do
  "$bin/simulate" --world "$root/worlds/${first_world[$config]}.yaml" --output "$work/first.bag" \
    --seed 1 --duration 60 >/dev/null
  /usr/bin/python3 "$root/test/tools/join_bags.py" "$work/first.bag" "$work/second.bag" \
    "$work/both.bag"
  "$bin/offline_slam" --bag "$work/both.bag" --config "$root/config/$config.yaml" \
    --reference "$work/second.ref.tum" --output "$work/$config" --seed 1 --no-progress \
    >"$work/$config.log" 2>&1 || { echo "FAIL: $config: offline_slam failed"; cat "$work/$config.log"; exit 1; }
  /usr/bin/python3 - "$work/$config/summary.json" "$config" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
name = sys.argv[2]
problems = []
segments = s.get("tf_segments", 1)
if segments != 2:
    problems.append("tf_segments %d, expected 2 (one per log)" % segments)
if s["resets"] != 1:
    problems.append("resets %d, expected 1 (a new map for the second log)" % s["resets"])
if not s["ate_rmse_m"] < 0.3:
    problems.append("ATE of the second log %.3f m, expected < 0.3 m" % s["ate_rmse_m"])
print("%s: tf_segments %d, resets %d, ATE of the second log %.3f m"
      % (name, segments, s["resets"], s["ate_rmse_m"]))
if problems:
    print("FAIL: " + name + ": " + "; ".join(problems))
    sys.exit(1)
PY
done
echo "PASS"
