#!/usr/bin/env bash
# Sensors on one topic each, as GCtronic's e-puck driver publishes them (/proximity0 .. 7, frames
# epuck2_robot_0/base_link and base_prox0 .. 7; test/tools/epuck_driver_bag.py), read with
# sonar_topic as a list: offline_slam must give exactly the trajectory of the simulator's bag
# (every reading on `ir`, frames base_link and ir_N) with config/grid_pf.yaml; a misspelt topic
# in the list is named on stderr; and config/grid_pf_epuck.yaml on the driver's ranges (5 cm,
# 0.26 rad) must beat odometry.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam evaluate

topics="[proximity0,proximity1,proximity2,proximity3,proximity4,proximity5,proximity6,proximity7]"
"$bin/simulate" --world "$root/worlds/yatim_epuck.yaml" --output "$work/sim.bag" --seed 1 >/dev/null
/usr/bin/python3 "$root/test/tools/epuck_driver_bag.py" "$work/sim.bag" "$work/names.bag" >/dev/null
/usr/bin/python3 "$root/test/tools/epuck_driver_bag.py" "$work/sim.bag" "$work/driver.bag" \
  --driver-ranges >/dev/null

run() {  # NAME BAG CONFIG [--set ...]
  local name=$1 bag=$2 config=$3
  shift 3
  "$bin/offline_slam" --bag "$work/$bag" --config "$root/config/$config" --output "$work/$name" \
    --reference "$work/sim.ref.tum" --no-progress "$@" >"$work/$name.log" 2>&1 ||
    { echo "FAIL: offline_slam ($name)"; cat "$work/$name.log"; exit 1; }
}
run one_topic sim.bag grid_pf.yaml
run eight_topics names.bag grid_pf.yaml --set "sonar_topic=$topics" \
  --set base_frame=epuck2_robot_0/base_link
run misspelt names.bag grid_pf.yaml --set "sonar_topic=${topics/proximity7/proximty7}" \
  --set base_frame=epuck2_robot_0/base_link
run driver driver.bag grid_pf_epuck.yaml

status=0
if cmp -s "$work/one_topic/trajectory.tum" "$work/eight_topics/trajectory.tum"; then
  echo "ok: eight topics give the one topic's trajectory ($(wc -l <"$work/one_topic/trajectory.tum") poses)"
else
  echo "FAIL: the trajectories from one topic and from eight differ"; status=1
fi
if grep -q "no message on sonar topic 'proximty7'" "$work/misspelt.log"; then
  echo "ok: the misspelt topic is named"
else
  echo "FAIL: the misspelt topic is not named:"; cat "$work/misspelt.log"; status=1
fi
# Odometry's ATE: the bag's /odom against the ground truth.
/usr/bin/python3 - "$work/sim.bag" "$work/odom.tum" <<'PY'
import sys
import rosbag
with rosbag.Bag(sys.argv[1]) as bag, open(sys.argv[2], "w") as out:
    for _, m, _ in bag.read_messages(topics=["/odom"]):
        p, q = m.pose.pose.position, m.pose.pose.orientation
        out.write("%.6f %.6f %.6f 0 %.9f %.9f %.9f %.9f\n" %
                  (m.header.stamp.to_sec(), p.x, p.y, q.x, q.y, q.z, q.w))
PY
"$bin/evaluate" "$work/odom.tum" "$work/sim.ref.tum" >"$work/odom.json"
/usr/bin/python3 - "$work/odom.json" "$work/driver/summary.json" <<'PY' || status=1
import json, sys
odom = json.load(open(sys.argv[1]))["ate_rmse_m"]
summary = json.load(open(sys.argv[2]))
filt = summary["ate_rmse_m"]
# Offline on world seeds 1-7 grid_pf_epuck.yaml gave 0.39-0.99 of odometry's ATE (0.39 here).
print("grid_pf_epuck.yaml on the driver's ranges: ATE %.4f m, odometry %.4f m (ratio %.2f), %d updates"
      % (filt, odom, filt / odom, summary["updates"]))
if not filt <= 0.7 * odom:
    sys.exit("FAIL: not clearly better than odometry (at most 0.7 of its ATE)")
PY
[ "$status" -eq 0 ] && echo "PASS"
exit "$status"
