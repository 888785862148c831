#!/usr/bin/env bash
# Sonar echoes as a cloud (sonar_source: cloud), as RosAria publishes them: the simulator's
# sensor_msgs/PointCloud, and the same clouds as sensor_msgs/PointCloud2 (RosAria's
# sonar_pointcloud2, test/tools/cloud_to_cloud2.py). offline_slam must map both (lee_sonar_room
# world), with the same result. Before session 13 a PointCloud2 was counted as a malformed
# message and nothing was mapped.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam

"$bin/simulate" --world "$root/worlds/lee_sonar_room.yaml" --output "$work/cloud.bag" --seed 2 \
  --duration 150 >/dev/null
/usr/bin/python3 "$root/test/tools/cloud_to_cloud2.py" "$work/cloud.bag" "$work/cloud2.bag"
for bag in cloud cloud2; do
  "$bin/offline_slam" --bag "$work/$bag.bag" --config "$root/config/sonar_fastslam2.yaml" \
    --set sonar_source=cloud --set features_topic=none --reference "$work/cloud.ref.tum" \
    --output "$work/$bag" --seed 1 --no-progress >"$work/$bag.log" 2>&1 ||
    { echo "FAIL: offline_slam on $bag.bag"; cat "$work/$bag.log"; exit 1; }
done
/usr/bin/python3 - "$work" <<'PY'
import json, sys
work = sys.argv[1]
one, two = (json.load(open("%s/%s/summary.json" % (work, b))) for b in ("cloud", "cloud2"))
same = open(work + "/cloud/trajectory.tum").read() == open(work + "/cloud2/trajectory.tum").read()
print("PointCloud: %d updates, ATE %.3f m; PointCloud2: %d updates, ATE %.3f m, %d malformed; "
      "same trajectory: %s" % (one["updates"], one.get("ate_rmse_m", float("nan")),
                               two["updates"], two.get("ate_rmse_m", float("nan")),
                               two["dropped_bad_message"], same))
problems = []
if one["updates"] < 20:
    problems.append("the PointCloud run made only %d updates" % one["updates"])
if two["dropped_bad_message"] > 0 or not same:
    problems.append("the PointCloud2 copy was not mapped like the PointCloud original")
if problems:
    print("FAIL: " + "; ".join(problems))
    sys.exit(1)
PY
echo PASS
