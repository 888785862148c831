#!/usr/bin/env bash
# Map, save, reuse: maps worlds/test_small.yaml with the laser config (offline_slam), then runs
# a second simulated run (another seed) in localization-only mode on the saved landmarks
# (map_file + localization_only). Fails unless the second run tracks the robot (ATE under
# 0.15 m against the ground truth) without adding a landmark, and unless a missing map_file
# and localization_only without map_file are refused with a message naming the key. The
# mapping run also writes --output-bag, which must hold a pose per update, markers, the
# trajectory every 10 s of bag time (growing, the last one a pose per update), and the input's
# tf, odometry and scans.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam
config="$root/config/laser_fastslam2.yaml"
world="$root/worlds/test_small.yaml"

"$bin/simulate" --world "$world" --output "$work/a.bag" --seed 11 >/dev/null
"$bin/offline_slam" --bag "$work/a.bag" --config "$config" --output "$work/map" --no-progress \
  --reference "$work/a.ref.tum" --output-bag "$work/map/results.bag" >/dev/null
"$bin/simulate" --world "$world" --output "$work/b.bag" --seed 12 >/dev/null
"$bin/offline_slam" --bag "$work/b.bag" --config "$config" --output "$work/loc" --no-progress \
  --reference "$work/b.ref.tum" --set "map_file=$work/map/landmarks.yaml" \
  --set localization_only=true >/dev/null

/usr/bin/python3 - "$work" <<'PY'
import json, sys, yaml
work = sys.argv[1]
saved = yaml.safe_load(open(work + "/map/landmarks.yaml"))["landmarks"]
after = yaml.safe_load(open(work + "/loc/landmarks.yaml"))["landmarks"]
summary = json.load(open(work + "/loc/summary.json"))
print("saved map: %d landmarks; localization run: %d landmarks, ATE %.3f m, %d updates"
      % (len(saved), len(after), summary["ate_rmse_m"], summary["updates"]))
ok = True
if len(after) != len(saved):
    print("FAIL: localization-only changed the landmark count"); ok = False
if sorted(l["id"] for l in after) != sorted(l["id"] for l in saved):
    print("FAIL: localization-only changed the landmark ids"); ok = False
if not summary["ate_rmse_m"] < 0.15:
    print("FAIL: ATE %.3f m >= 0.15 m" % summary["ate_rmse_m"]); ok = False
if summary["updates"] < 100:
    print("FAIL: only %d updates" % summary["updates"]); ok = False
import rosbag
mapping = json.load(open(work + "/map/summary.json"))
with rosbag.Bag(work + "/map/results.bag") as bag:
    counts = {t: i.message_count for t, i in bag.get_type_and_topic_info().topics.items()}
print("--output-bag topics:", counts)
if counts.get("/rbpf_slam_node/pose") != mapping["updates"]:
    print("FAIL: --output-bag has %s poses for %d updates"
          % (counts.get("/rbpf_slam_node/pose"), mapping["updates"])); ok = False
for topic in ("/rbpf_slam_node/landmarks", "/rbpf_slam_node/trajectory", "/tf", "/tf_static", "/scan",
              "/odom"):
    if not counts.get(topic):
        print("FAIL: --output-bag has no " + topic); ok = False
with rosbag.Bag(work + "/map/results.bag") as bag:
    paths = [(t.to_sec(), len(m.poses)) for _, m, t in bag.read_messages(topics=["/rbpf_slam_node/trajectory"])]
    span = bag.get_end_time() - bag.get_start_time()
print("--output-bag trajectories (bag time, poses):", [(round(t - paths[0][0], 1), n) for t, n in paths])
if len(paths) < int(span // 10):
    print("FAIL: %d trajectories over %.0f s of bag (one per 10 s)" % (len(paths), span)); ok = False
if any(b[1] < a[1] for a, b in zip(paths, paths[1:])) or paths[-1][1] != mapping["updates"]:
    print("FAIL: the trajectories do not grow to a pose per update (%d)" % mapping["updates"]); ok = False
sys.exit(0 if ok else 1)
PY

expect_refusal() {  # expect_refusal TEXT ARGS...: offline_slam must fail and print TEXT
  local text=$1
  shift
  if "$bin/offline_slam" --bag "$work/b.bag" --config "$config" --output "$work/bad" \
      --no-progress "$@" >"$work/bad.log" 2>&1; then
    echo "FAIL: offline_slam accepted $*"; exit 1
  fi
  grep -q "$text" "$work/bad.log" || { echo "FAIL: no '$text' in:"; cat "$work/bad.log"; exit 1; }
}
expect_refusal "map_file" --set "map_file=$work/none.yaml"
expect_refusal "localization_only" --set localization_only=true
echo "PASS"
