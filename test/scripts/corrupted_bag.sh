#!/usr/bin/env bash
# Corrupted copies of the bundled real slices (test/tools/corrupt_bag.py: invalid ranges, stale
# and duplicate stamps, a tf gap (a tenth of the bag), empty and unknown frames, malformed messages, a 3 m
# odometry jump, then the bag's start again with its own stamps) through offline_slam and
# through rbpf_slam_node (rosbag play --clock), for each case below: the laser front end on
# the Intel and the ACES slice, the sonar front end (Range messages) on the Intel slice, and
# range-bearing features on 150 s of MRCLAM robot 1 (converted at test time from
# the shared data's mrclam6, lib/shared_data.sh; skipped, and named in the last line, when that
# is not there).
# Fails if either crashes, writes or publishes anything non-finite, stops updating after any
# fault window, or does not start a new map at the loop; and offline_slam, if its gap check
# misses the tf gap or counts frames far apart as a gap while the odometry flows (1b).
#   test/scripts/corrupted_bag.sh [CASE ...]     (default: every case)
# A CASE may also be BAG:CONFIG:LANDMARKS for any bag (CONFIG a name in config/, LANDMARKS 1 if
# the map must hold landmarks at the end), e.g. ../shared/data/aces.bag:laser_fastslam2:1;
# RATE (default 10) is the node's playback rate.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
bin="${RBPF_BIN:-$root/build/devel/lib/rbpf_slam}"
[ -x "$bin/offline_slam" ] && [ -x "$bin/rbpf_slam_node" ] || { echo "FAIL: not built ($bin)"; exit 1; }
source "$here/lib/launch.sh"
source "$here/lib/shared_data.sh"
skipped=()

# name: bag, config, whether landmarks must exist at the end (the sonar ring of these logs, one every
# ~3 s, maps nothing; see docs/results.md).
declare -A case_bag=([intel_laser]=intel_head.bag [aces_laser]=aces_head.bag
  [intel_sonar]=intel_head.bag [mrclam_landmarks]=mrclam)
declare -A case_config=([intel_laser]=laser_fastslam2 [aces_laser]=laser_fastslam2
  [intel_sonar]=sonar_fastslam2 [mrclam_landmarks]=landmarks_fastslam2)
declare -A case_landmarks=([intel_laser]=1 [aces_laser]=1 [intel_sonar]=0 [mrclam_landmarks]=1)
cases=("$@")
[ ${#cases[@]} -gt 0 ] || cases=(intel_laser aces_laser intel_sonar mrclam_landmarks)

run_case() {
local name=$1
local config="$root/config/${case_config[$name]}.yaml"
local expect_landmarks=${case_landmarks[$name]}
local work="$work/$name"
mkdir -p "$work"
echo "== $name: ${case_bag[$name]} with ${case_config[$name]}"
local bag="${case_bag[$name]}"
[ "${bag#/}" != "$bag" ] || bag="$root/test/data/$bag"
if [ "${case_bag[$name]}" = mrclam ]; then
  local data
  data="$(shared_data_dir)/mrclam6"
  [ -d "$data" ] || { echo "SKIP $name: no shared data with mrclam6"; skipped+=("$name"); return 0; }
  bag="$work/mrclam.bag"
  "$bin/mrclam_to_bag" "$data" 1 "$bag" --duration 150 >"$work/convert.log" 2>&1 \
    || { echo "FAIL: mrclam_to_bag"; tail "$work/convert.log"; return 1; }
fi
/usr/bin/python3 "$root/test/tools/corrupt_bag.py" "$bag" "$work/corrupt.bag" >"$work/windows.json" \
  || { echo "FAIL: corrupt_bag.py"; return 1; }

# 1. The offline runner.
"$bin/offline_slam" --bag "$work/corrupt.bag" --config "$config" --output "$work/offline" \
  --no-progress --verbose >"$work/offline.log" 2>&1 || { echo "FAIL: offline_slam exited non-zero"; tail "$work/offline.log"; return 1; }

# 1b. The gap check measures how long the odometry was silent, not the frames: with
# max_time_gap at half the tf gap's length the corrupted bag has a gap and the original none
# (although frames may be further apart: the MRCLAM slice goes 24 and 27 s without a sighting).
# The odometry-jump rule, which counts gaps too (intel_head.bag holds a glitch), is off here.
local gap_limit
gap_limit=$(/usr/bin/python3 -c "import json; w = json.load(open('$work/windows.json'))['tf_gap']; print(0.5 * (w[1] - w[0]))") \
  || { echo "FAIL: no tf_gap window in $work/windows.json"; return 1; }
for input in corrupt original; do
  local input_bag="$work/corrupt.bag"
  [ $input = original ] && input_bag="$bag"
  "$bin/offline_slam" --bag "$input_bag" --config "$config" --output "$work/gap_$input" \
    --no-progress --verbose --set max_time_gap="$gap_limit" --set max_odometry_jump=0 \
    >"$work/gap_$input.log" 2>&1 \
    || { echo "FAIL: offline_slam (max_time_gap $gap_limit, $input bag) exited non-zero"; tail "$work/gap_$input.log"; return 1; }
done

# 2. The node, with the bag played at 10x and its outputs recorded.
cat >"$work/run.launch" <<LAUNCH
<launch>
  <param name="use_sim_time" value="true"/>
  <node pkg="rbpf_slam" type="rbpf_slam_node" name="rbpf_slam_node" output="screen">
    <rosparam command="load" file="$config"/>
  </node>
  <node pkg="rosbag" type="record" name="recorder"
        args="-O $work/node_out.bag /rbpf_slam_node/pose /tf"/>
  <node pkg="rosbag" type="play" name="player" required="true"
        args="--clock --quiet --delay=4 --rate=${RATE:-10} $work/corrupt.bag"/>
</launch>
LAUNCH
start_launch "$work/run.launch" "$work/node.log"
node=$(child_pid rbpf_slam_node)
[ -n "$node" ] || { echo "FAIL: rbpf_slam_node did not start"; tail -n 30 "$work/node.log"; return 1; }
# The player is required: roslaunch ends when it does (waited for: the bag's length at RATE,
# plus a minute).
local span
span=$(/usr/bin/python3 -c "import json; l = json.load(open('$work/windows.json'))['loop']; print(int(6 * (l[1] - l[0]) + 1))" 2>/dev/null || echo 600)
for _ in $(seq 1 $(( (span / ${RATE:-10} + 60) * 2 ))); do
  kill -0 "$launch" 2>/dev/null || break
  sleep 0.5
done
wait "$launch" 2>/dev/null || true
launch=""
# roslaunch reports a node that crashed (or exited) before shutdown as "process has died".
node_alive=1
grep -q "rbpf_slam_node-[0-9]*\] process has died" "$work/node.log" && node_alive=0
node_resets=$(grep -c "stamps went back\|time jumped back" "$work/node.log" || true)

/usr/bin/python3 - "$work" "$node_alive" "$node_resets" "$expect_landmarks" <<'PY'
import json, math, sys
import rosbag, yaml
work, node_alive, node_resets = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
expect_landmarks = int(sys.argv[4])
windows = json.load(open(work + "/windows.json"))
ok = True
def fail(why):
    global ok
    ok = False
    print("FAIL: " + why)

# Offline runner outputs.
for line in open(work + "/offline/trajectory.tum"):
    if line.startswith("#") or not line.strip():
        continue
    v = [float(x) for x in line.split()]
    if not all(math.isfinite(x) for x in v):
        fail("non-finite pose in trajectory.tum: " + line.strip())
# Every update of every run (trajectory.tum holds the last run only, after the loop's reset).
stamps = []
for line in open(work + "/offline.log"):
    if line.startswith("t=") and "pose=(" in line:
        stamps.append(float(line.split()[0][2:]))
        pose = line.split("pose=(")[1].split(")")[0].replace("deg", "").split()
        if not all(math.isfinite(float(x)) for x in pose):
            fail("offline: non-finite pose: " + line.strip())
summary = json.load(open(work + "/offline/summary.json"))
def numbers(value):
    if isinstance(value, dict):
        for v in value.values():
            yield from numbers(v)
    elif isinstance(value, list):
        for v in value:
            yield from numbers(v)
    elif isinstance(value, float):
        yield value
landmarks = yaml.safe_load(open(work + "/offline/landmarks.yaml"))["landmarks"] or []
for lm in landmarks:
    if not all(math.isfinite(x) for x in numbers(lm)):
        fail("offline: non-finite landmark %s" % lm)
if expect_landmarks and not landmarks:
    fail("offline: no landmarks at the end")
for name, (lo, hi) in windows.items():
    if name == "loop":
        continue
    if not any(s > hi for s in stamps):
        fail("offline: no update after the %s window" % name)
if summary["resets"] < 1:
    fail("offline: no new map at the loop (resets = %d)" % summary["resets"])
gaps = {k: json.load(open("%s/gap_%s/summary.json" % (work, k)))["gaps"] for k in ("corrupt", "original")}
# The gap must be met once, at the last update before the tf hole (its odometry may already be
# interpolated across the hole), in it, or at the first update after it.
hole_lo, hole_hi = windows["tf_gap"]
gap_stamps, all_stamps = [], []
for line in open(work + "/gap_corrupt.log"):
    if line.startswith("t=") and " gaps=" in line:
        t = float(line.split()[0][2:])
        all_stamps.append(t)
        if int(line.split(" gaps=")[1].split()[0]) >= 1 and not gap_stamps:
            gap_stamps.append(t)
after = [t for t in all_stamps if t >= hole_hi]
before = [t for t in all_stamps if t < hole_lo]
if gaps["corrupt"] != 1 or not gap_stamps:
    fail("offline: %d odometry gaps with max_time_gap half the tf hole's length, expected 1"
         % gaps["corrupt"])
elif not ((before[-1] if before else hole_lo) <= gap_stamps[0] <= (after[0] if after else float("inf"))):
    fail("offline: the first odometry gap at %.2f, not at the tf hole (%.2f-%.2f)"
         % (gap_stamps[0], hole_lo, hole_hi))
if gaps["original"] != 0:
    fail("offline: %d gaps in the original bag with max_time_gap half the tf gap's length "
         "(frames far apart with the odometry flowing are no gap)" % gaps["original"])
print("offline: %d updates, %d resets, %d rejected, %d malformed, %d without tf, %d landmarks"
      % (summary["updates"], summary["resets"], summary["rejected"],
         summary["dropped_bad_message"], summary["dropped_no_tf"], summary["landmarks"]))

# Node outputs.
if not node_alive:
    fail("rbpf_slam_node died")
poses, map_odom = [], []
with rosbag.Bag(work + "/node_out.bag") as bag:
    for topic, msg, _ in bag.read_messages():
        if topic.endswith("/pose"):
            p = msg.pose.pose
            vals = [p.position.x, p.position.y, p.orientation.z, p.orientation.w] + list(msg.pose.covariance)
            if not all(math.isfinite(x) for x in vals):
                fail("node published a non-finite pose at %.2f" % msg.header.stamp.to_sec())
            poses.append(msg.header.stamp.to_sec())
        else:
            for t in msg.transforms:
                if t.header.frame_id == "map" and t.child_frame_id == "odom":
                    q = t.transform
                    if not all(math.isfinite(x) for x in (q.translation.x, q.translation.y, q.rotation.z, q.rotation.w)):
                        fail("node published a non-finite map -> odom")
                    map_odom.append(t.header.stamp.to_sec())
for name, (lo, hi) in windows.items():
    if name == "loop":
        continue
    if not any(lo < s and s > hi for s in poses):
        fail("node: no update after the %s window" % name)
# After the loop the stamps start over: updates must come again with the loop's own stamps.
loop_start = windows["loop"][0]
after_loop = [s for i, s in enumerate(poses) if i > 0 and s < poses[i - 1] - 10.0]
if node_resets < 1 or not after_loop:
    fail("node: no new map at the loop (%d clock resets, %d updates after it)" % (node_resets, len(after_loop)))
repeated = sum(1 for a, b in zip(map_odom, map_odom[1:]) if b == a)
if repeated:
    fail("node: %d map -> odom transforms repeated the previous stamp" % repeated)
print("node: %d poses, %d map -> odom, %d clock resets" % (len(poses), len(map_odom), node_resets))
print("PASS" if ok else "FAIL")
sys.exit(0 if ok else 1)
PY
}

status=0
for name in "${cases[@]}"; do
  if [[ "$name" == *.bag:*:* ]]; then  # BAG:CONFIG:LANDMARKS
    IFS=: read -r path config landmarks <<<"$name"
    name=$(basename "$path" .bag)_$config
    case_bag[$name]=$(cd "$(dirname "$path")" && pwd)/$(basename "$path")
    case_config[$name]=$config
    case_landmarks[$name]=$landmarks
  fi
  [ -n "${case_bag[$name]:-}" ] || { echo "FAIL: no case '$name' (${!case_bag[*]})"; exit 2; }
  run_case "$name" || status=1
done
ran=()
for name in "${cases[@]}"; do
  [[ " ${skipped[*]} " == *" $name "* ]] || ran+=("$name")
done
if [ ${#skipped[@]} -gt 0 ]; then echo "skipped (no data): ${skipped[*]}"; fi
if [ $status -ne 0 ]; then echo "FAIL"; exit $status; fi
if [ ${#ran[@]} -eq 0 ]; then echo "SKIP: every case lacks its data"; exit 77; fi
echo "PASS: ${ran[*]}"
