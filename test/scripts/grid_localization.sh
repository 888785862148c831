#!/usr/bin/env bash
# grid_pf localizes on a saved occupancy-grid map (map_file + localization_only, map_server's
# map.yaml): on the simulated e-puck world, with the arena's floor plan as the map, the path
# must stay within 1.5 cm of the truth in the map frame (no alignment) and beat the odometry,
# and the map must come out as loaded. Started 3 cm and 0.11 rad off (--initial-pose with its
# uncertainty, or the same as a recorded /initialpose in the bag) it must find the robot; an
# initialpose in another frame is ignored and named. A map saved by a grid_pf mapping run loads
# back unchanged, and the same run localized on it follows the path it was mapped along; each
# kind of variant names a map file of the other kind. With no start given
# (--global-localization) the particles spread over the plan gather on the robot, or on its
# mirror image in the symmetric arena.
# The live node on the same map: test/rostest/grid_localization.test.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam evaluate
config="$root/config/grid_pf.yaml"
world="$root/worlds/yatim_epuck.yaml"

"$bin/simulate" --world "$world" --output "$work/a.bag" --seed 1 >/dev/null
"$bin/simulate" --world "$world" --output "$work/b.bag" --seed 2 >/dev/null

# The floor plan (test/tools/floor_plan.py): walls and object outlines occupied, the arena's
# floor free, 1 cm cells; test/data/epuck_floor_plan.* (grid_localization.test's map) must be it.
/usr/bin/python3 "$here/../tools/floor_plan.py" "$world" "$work/plan"
cmp "$work/plan.pgm" "$root/test/data/epuck_floor_plan.pgm" ||
  { echo "FAIL: test/data/epuck_floor_plan.pgm is not floor_plan.py's map of $world"; exit 1; }

# The odometry as a TUM trajectory, and the bag with a recorded initialpose (good, then one in
# the odometry frame, which must be ignored) before its first scan.
/usr/bin/python3 - "$work" <<'PY'
import sys, rosbag, rospy
from geometry_msgs.msg import PoseWithCovarianceStamped
work = sys.argv[1]
with rosbag.Bag(work + "/b.bag") as bag, open(work + "/b.odom.tum", "w") as f:
    for _, m, _ in bag.read_messages(topics=["/odom"]):
        p, q = m.pose.pose.position, m.pose.pose.orientation
        f.write("%.9f %.6f %.6f 0 %.9f %.9f %.9f %.9f\n" % (m.header.stamp.to_sec(), p.x, p.y, q.x, q.y, q.z, q.w))
    start = bag.get_start_time()
    with rosbag.Bag(work + "/b_initialpose.bag", "w") as out:
        for frame in ("map", "odom"):
            msg = PoseWithCovarianceStamped()
            msg.header.frame_id = frame
            msg.header.stamp = rospy.Time.from_sec(start - 0.01)  # before the first scan
            msg.pose.pose.position.x, msg.pose.pose.position.y = 0.10, 0.065
            msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = 0.0549723, 0.9984879  # 0.11 rad
            msg.pose.covariance[0] = msg.pose.covariance[7] = 0.03 ** 2
            msg.pose.covariance[35] = 0.15 ** 2
            out.write("/initialpose", msg, msg.header.stamp)
        for topic, m, t, in bag.read_messages(return_connection_header=False):
            out.write(topic, m, t)
PY

run() {  # NAME BAG [args...]
  local name=$1 bag=$2
  shift 2
  "$bin/offline_slam" --bag "$work/$bag" --config "$config" --output "$work/$name" --no-progress \
    --reference "$work/${bag%%[._]*}.ref.tum" "$@" >"$work/$name.log" 2>&1 ||
    { echo "FAIL: offline_slam ($name)"; cat "$work/$name.log"; exit 1; }
}
loc=(--set localization_only=true)
run plan b.bag --set "map_file=$work/plan.yaml" "${loc[@]}"
run off b.bag --set "map_file=$work/plan.yaml" "${loc[@]}" --initial-pose 0.10,0.065,0.11,0.03,0.15
run recorded b_initialpose.bag --set "map_file=$work/plan.yaml" "${loc[@]}"
run mapped a.bag
run reloaded a.bag --set "map_file=$work/mapped/map.yaml" "${loc[@]}"

status=0
/usr/bin/python3 - "$work" "$bin/evaluate" <<'PY' || status=1
import json, math, subprocess, sys
work, evaluate = sys.argv[1:]
def load(path):
    out = []
    for line in open(path):
        v = line.split()
        if len(v) == 8 and not v[0].startswith("#"):
            out.append((float(v[0]), float(v[1]), float(v[2]), 2 * math.atan2(float(v[6]), float(v[7]))))
    return out
truth = {round(p[0], 3): p for p in load(work + "/b.ref.tum")}
def errors(path):  # position error in the map frame at each pose (the truth at the same stamp)
    return [math.hypot(p[1] - truth[round(p[0], 3)][1], p[2] - truth[round(p[0], 3)][2])
            for p in load(path) if round(p[0], 3) in truth]
def rms(e): return math.sqrt(sum(x * x for x in e) / len(e))
def ate(path):
    return json.loads(subprocess.check_output([evaluate, path, work + "/b.ref.tum", "--no-align"]))["ate_rmse_m"]
summary = {n: json.load(open("%s/%s/summary.json" % (work, n))) for n in ("plan", "off", "recorded", "mapped", "reloaded")}
logs = {n: open("%s/%s.log" % (work, n)).read() for n in summary}
odometry = ate(work + "/b.odom.tum")
fails = []
plan = ate(work + "/plan/trajectory.tum")
print("on the floor plan: %.4f m in the map frame, odometry %.4f m" % (plan, odometry))
if not (plan < 0.015 and plan < odometry):
    fails.append("localization on the floor plan %.4f m (odometry %.4f m)" % (plan, odometry))
if abs(summary["plan"].get("ate_map_frame_rmse_m", -1) - plan) > 1e-6:
    fails.append("summary.json's ate_map_frame_rmse_m %s is not evaluate --no-align's %.6f"
                 % (summary["plan"].get("ate_map_frame_rmse_m"), plan))
if "map_file: a 140 x 110 grid of 0.01 m cells (415 occupied" not in logs["plan"]:
    fails.append("offline_slam does not say what map_file loaded")
occupied = open(work + "/plan.pgm", "rb").read().split(b"\n", 3)[3].count(b"\x00")
if summary["plan"]["map_occupied_cells"] != occupied:
    fails.append("the map changed: %d occupied cells, the floor plan has %d" % (summary["plan"]["map_occupied_cells"], occupied))
for name in ("off", "recorded"):
    e = errors("%s/%s/trajectory.tum" % (work, name))
    first, late = e[0], rms(e[len(e) // 2:])
    print("started off (%s): first pose %.3f m off, second half %.4f m" % (name, first, late))
    if not (first > 0.02 and late < 0.015):
        fails.append("%s: not found from the wrong start (first %.3f m, second half %.4f m)" % (name, first, late))
if summary["off"]["initial_poses"] != 1:
    fails.append("--initial-pose not counted in initial_poses (%d)" % summary["off"]["initial_poses"])
if summary["recorded"]["initial_poses"] != 1 or summary["recorded"]["ignored_initial_poses"] != 1:
    fails.append("recorded initialpose: %d taken, %d ignored (expected 1 and 1)"
                 % (summary["recorded"]["initial_poses"], summary["recorded"]["ignored_initial_poses"]))
if "in frame 'odom': expected the map frame 'map'" not in logs["recorded"]:
    fails.append("the initialpose in the odometry frame is not named")
if summary["reloaded"]["map_occupied_cells"] != summary["mapped"]["map_occupied_cells"]:
    fails.append("a saved map did not load back: %d occupied cells, saved %d"
                 % (summary["reloaded"]["map_occupied_cells"], summary["mapped"]["map_occupied_cells"]))
# The same run localized on its own saved map follows the path the map was made along: 0.0128 m
# apart; the map loaded 3 cm off along x takes the path with it, 0.0196 m apart.
mapped = {round(p[0], 3): p for p in load(work + "/mapped/trajectory.tum")}
apart = rms([math.hypot(p[1] - mapped[round(p[0], 3)][1], p[2] - mapped[round(p[0], 3)][2])
             for p in load(work + "/reloaded/trajectory.tum") if round(p[0], 3) in mapped])
print("the mapping run on its own saved map (%d occupied cells): %.4f m from its mapping path"
      % (summary["mapped"]["map_occupied_cells"], apart))
if not apart < 0.016:
    fails.append("on its own saved map the run is %.4f m from the path it mapped along" % apart)
for f in fails: print("FAIL: " + f)
sys.exit(1 if fails else 0)
PY

# A map of the other kind is named: landmarks for grid_pf, a grid for a landmark variant.
if "$bin/offline_slam" --bag "$work/b.bag" --config "$config" --output "$work/wrong" --no-progress \
  --set "map_file=$work/a.landmarks.yaml" >"$work/wrong.log" 2>&1; then
  echo "FAIL: grid_pf took a landmarks YAML as its map"; status=1
elif ! grep -q "a landmarks YAML; variant grid_pf maps cells" "$work/wrong.log"; then
  echo "FAIL: grid_pf's error for a landmarks YAML:"; cat "$work/wrong.log"; status=1
fi
if "$bin/offline_slam" --bag "$work/b.bag" --config "$root/config/landmarks_fastslam2.yaml" \
  --output "$work/wrong2" --no-progress --set "map_file=$work/plan.yaml" >"$work/wrong2.log" 2>&1; then
  echo "FAIL: a landmark variant took an occupancy-grid map"; status=1
elif ! grep -q "an occupancy-grid map (map_server's map.yaml)" "$work/wrong2.log"; then
  echo "FAIL: the landmark variant's error for a grid map:"; cat "$work/wrong2.log"; status=1
fi
# Global localization (--global-localization): no start given, the particles spread over the
# plan's free cells (3000 particles, free cells weighing 0.2). The e-puck drives round the
# rectangular arena 8 cm from its walls and its 7 cm infrared sees only them, so the pose turned
# by half a turn about the arena's centre, (1.2 - x, 0.9 - y, yaw + pi), sees exactly the same:
# each run must end on the truth or on that mirror, never between (filter seeds 1-6 did, 4 on
# the truth, each within 1.8 cm RMS over the last quarter; with the present order of random
# draws seeds 1 / 2 / 3 end on mirror / truth / truth; docs/results.md, grid PF, session 46).
# The likelihood field (grid.match_model: likelihood_field, the config's 2 cm sigma) needs no
# lower free weight and ends closer: seeds 1-3 on the truth within 0.7 cm (7 of seeds 1-8 on the
# truth, session 47); asserted as truth-or-mirror within 1.5 cm.
# Without a grid map, while mapping, or with a start pose as well, it is refused by name.
for s in 1 2 3; do
  run "global$s" b.bag --set "map_file=$work/plan.yaml" "${loc[@]}" --global-localization \
    --set particles=3000 --set grid.match_free_weight=0.2 --seed "$s"
  run "field$s" b.bag --set "map_file=$work/plan.yaml" "${loc[@]}" --global-localization \
    --set particles=3000 --set grid.match_model=likelihood_field --seed "$s"
done
/usr/bin/python3 - "$work" <<'PY' || status=1
import json, math, sys
work = sys.argv[1]
def load(path):
    return [[float(x) for x in l.split()] for l in open(path) if l.strip() and not l.startswith("#")]
truth = {round(p[0], 3): p for p in load(work + "/b.ref.tum")}
fails = []
def rms(v): return math.sqrt(sum(x * x for x in v) / len(v))
for name, s, bound in [(n, s, b) for n, b in (("global", 0.025), ("field", 0.015)) for s in (1, 2, 3)]:
    summary = json.load(open("%s/%s%d/summary.json" % (work, name, s)))
    if summary.get("global_localization") is not True:
        fails.append("%s seed %d: summary.json's global_localization is %s" % (name, s, summary.get("global_localization")))
    path = [p for p in load("%s/%s%d/trajectory.tum" % (work, name, s)) if round(p[0], 3) in truth]
    on = [math.hypot(p[1] - truth[round(p[0], 3)][1], p[2] - truth[round(p[0], 3)][2]) for p in path]
    mirror = [math.hypot(p[1] - (1.2 - truth[round(p[0], 3)][1]), p[2] - (0.9 - truth[round(p[0], 3)][2]))
              for p in path]
    n = len(path) // 4
    print("global localization (%s), seed %d: first pose %.3f m off; last quarter %.4f m RMS from "
          "the truth, %.4f m from its mirror" % (name, s, on[0], rms(on[-n:]), rms(mirror[-n:])))
    if not on[0] > 0.1:
        fails.append("%s seed %d: the first pose is %.3f m from the truth: not spread over the map"
                     % (name, s, on[0]))
    if not min(rms(on[-n:]), rms(mirror[-n:])) < bound:
        fails.append("%s seed %d: ends neither on the truth nor on its mirror within %.3f m (%.4f / %.4f m)"
                     % (name, s, bound, rms(on[-n:]), rms(mirror[-n:])))
for f in fails: print("FAIL: " + f)
sys.exit(1 if fails else 0)
PY
if "$bin/offline_slam" --bag "$work/b.bag" --config "$config" --output "$work/noglobal" --no-progress \
  --global-localization >"$work/noglobal.log" 2>&1; then
  echo "FAIL: --global-localization ran without a map"; status=1
elif ! grep -q "global-localization (grid_pf .*): no grid map is loaded" "$work/noglobal.log"; then
  echo "FAIL: --global-localization's error without a map:"; cat "$work/noglobal.log"; status=1
fi
if "$bin/offline_slam" --bag "$work/b.bag" --config "$config" --output "$work/mapping" --no-progress \
  --set "map_file=$work/plan.yaml" --global-localization >"$work/mapping.log" 2>&1; then
  echo "FAIL: --global-localization ran while mapping"; status=1
elif ! grep -q "mapping is on: global localization needs localization_only" "$work/mapping.log"; then
  echo "FAIL: --global-localization's error while mapping:"; cat "$work/mapping.log"; status=1
fi
if "$bin/offline_slam" --bag "$work/b.bag" --config "$config" --output "$work/both" --no-progress \
  --set "map_file=$work/plan.yaml" --global-localization --initial-pose 0,0,0 >"$work/both.log" 2>&1; then
  echo "FAIL: --global-localization ran with --initial-pose"; status=1
elif ! grep -q "exclude each other" "$work/both.log"; then
  echo "FAIL: --global-localization with --initial-pose:"; cat "$work/both.log"; status=1
fi
# The config key (global_localization: true; the launch files' global_localization:=true) starts
# as the flag does: the same trajectory as field seed 1. It needs localization_only, and
# excludes a start pose too.
run key1 b.bag --set "map_file=$work/plan.yaml" "${loc[@]}" --set global_localization=true \
  --set particles=3000 --set grid.match_model=likelihood_field --seed 1
if ! cmp -s "$work/key1/trajectory.tum" "$work/field1/trajectory.tum"; then
  echo "FAIL: global_localization: true ran otherwise than --global-localization"; status=1
elif ! /usr/bin/python3 -c "import json,sys; sys.exit(0 if json.load(open('$work/key1/summary.json'))['global_localization'] is True else 1)"; then
  echo "FAIL: summary.json's global_localization with the config key"; status=1
fi
if "$bin/offline_slam" --bag "$work/b.bag" --config "$config" --output "$work/keymapping" \
  --no-progress --set "map_file=$work/plan.yaml" --set global_localization=true \
  >"$work/keymapping.log" 2>&1; then
  echo "FAIL: global_localization: true ran while mapping"; status=1
elif ! grep -q "global_localization = true needs localization_only" "$work/keymapping.log"; then
  echo "FAIL: global_localization: true's error while mapping:"; cat "$work/keymapping.log"; status=1
fi
if "$bin/offline_slam" --bag "$work/b.bag" --config "$config" --output "$work/keyboth" --no-progress \
  --set "map_file=$work/plan.yaml" "${loc[@]}" --set global_localization=true \
  --initial-pose 0,0,0 >"$work/keyboth.log" 2>&1; then
  echo "FAIL: global_localization: true ran with --initial-pose"; status=1
elif ! grep -q "initial-pose and global_localization: true exclude each other" "$work/keyboth.log"; then
  echo "FAIL: global_localization: true with --initial-pose:"; cat "$work/keyboth.log"; status=1
fi
[ $status -eq 0 ] && echo "ok: grid_pf localizes on a saved map"
exit $status
