#!/usr/bin/env bash
# validate_bag: a clean simulated bag and the bundled intel_head.bag pass (exit 0); a copy of the
# simulated one with injected faults (a scan
# stamped back in time, a repeated scan stamp, a scan in a frame tf does not know, NaN ranges,
# 5 s without odometry tf (a note), NaN poses on /odom for 1 s) fails (exit 1) with each fault
# named; odometry silent for 40 s is a problem, sensor gaps are notes. Given frames the bag does
# not use, the problem names the frames its tf holds.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate validate_bag

"$bin/simulate" --world "$root/worlds/test_small.yaml" --output "$work/clean.bag" --seed 4 >/dev/null
if ! "$bin/validate_bag" "$work/clean.bag" >"$work/clean.txt"; then
  echo "FAIL: the clean bag was reported:"; cat "$work/clean.txt"; exit 1
fi
grep -q "no problems found" "$work/clean.txt" || { echo "FAIL: no verdict"; exit 1; }
# Frames the bag does not use: the problem names what its tf does hold.
"$bin/validate_bag" "$work/clean.bag" --base-frame robot >"$work/frames.txt" || true
grep -q "tf never connects odom and robot: .*the bag's tf has odom -> 'base_link': is one of those the base frame" \
  "$work/frames.txt" || { echo "FAIL: no base frame hint:"; grep PROBLEM "$work/frames.txt"; exit 1; }
"$bin/validate_bag" "$work/clean.bag" --odom-frame world >"$work/frames.txt" || true
grep -q "the bag's tf starts at 'odom': is one of those the odometry frame" "$work/frames.txt" ||
  { echo "FAIL: no odometry frame hint:"; grep PROBLEM "$work/frames.txt"; exit 1; }
# Short streams: four scans 3 s apart are no gap, a 40 s hole among four scans is one.
/usr/bin/python3 - "$work" <<'PY'
import sys
import rosbag, rospy
from sensor_msgs.msg import LaserScan
for name, times in (("steady", [10, 13, 16, 19]), ("hole", [10, 13, 16, 56])):
    with rosbag.Bag("%s/%s.bag" % (sys.argv[1], name), "w") as out:
        for t in times:
            scan = LaserScan()
            scan.header.stamp = rospy.Time(t)
            scan.header.frame_id = "base_link"
            out.write("/scan", scan, rospy.Time(t))
PY
# validate_bag exits 0 for no problem, 1 for problems found; anything else (a crash, a refused
# argument) is a failure of the test, and the steady bag must get its /scan summary line.
for name in steady hole; do
  result=0
  "$bin/validate_bag" "$work/$name.bag" --max-gap 2 >"$work/$name.txt" 2>&1 || result=$?
  if [ "$result" -gt 1 ]; then echo "FAIL: validate_bag $name.bag exited $result:"; cat "$work/$name.txt"; exit 1; fi
done
grep -qE "^ */scan +4 messages" "$work/steady.txt" \
  || { echo "FAIL: no /scan summary for the steady bag:"; cat "$work/steady.txt"; exit 1; }
if grep -q "/scan: .*gap" "$work/steady.txt"; then
  echo "FAIL: scans 3 s apart reported as gaps:"; grep gap "$work/steady.txt"; exit 1
fi
grep -q "/scan: 1 gap" "$work/hole.txt" || { echo "FAIL: the 40 s hole was missed:"; cat "$work/hole.txt"; exit 1; }
# Odometry silent for 40 s (over SLAM's default max_time_gap, 30 s) is a problem; sensor gaps
# and shorter odometry pauses are notes (time without data; the bundled ACES slice has 37 s
# without a scan and maps fine).
/usr/bin/python3 - "$work" <<'PY'
import sys
import rosbag, rospy
from tf2_msgs.msg import TFMessage
from geometry_msgs.msg import TransformStamped
with rosbag.Bag("%s/odomhole.bag" % sys.argv[1], "w") as out:
    for t in [10, 11, 12, 13, 14, 54, 55, 56]:
        tr = TransformStamped()
        tr.header.stamp = rospy.Time(t)
        tr.header.frame_id = "odom"
        tr.child_frame_id = "base_link"
        tr.transform.rotation.w = 1.0
        out.write("/tf", TFMessage(transforms=[tr]), rospy.Time(t))
PY
result=0
"$bin/validate_bag" "$work/odomhole.bag" >"$work/odomhole.txt" 2>&1 || result=$?
[ "$result" -eq 1 ] && grep -q "PROBLEM: tf odom -> base_link: 1 gap(s).*SLAM's default max_time_gap" \
  "$work/odomhole.txt" || { echo "FAIL: a 40 s odometry hole (exit $result):"; cat "$work/odomhole.txt"; exit 1; }
if ! "$bin/validate_bag" "$root/test/data/aces_head.bag" >"$work/aces.txt"; then
  echo "FAIL: aces_head.bag was reported:"; grep PROBLEM "$work/aces.txt" | head; exit 1
fi
grep -q "note: /scan: 4 gap(s)" "$work/aces.txt" || { echo "FAIL: aces_head.bag's scan gaps not noted"; cat "$work/aces.txt"; exit 1; }
# A real log that maps fine (a scan every ~3 s, repeated odometry stamps that SLAM skips) is
# no problem either; before session 13 it gave 80 "gaps" and exit 1.
if ! "$bin/validate_bag" "$root/test/data/intel_head.bag" >"$work/intel.txt"; then
  echo "FAIL: intel_head.bag was reported:"; grep PROBLEM "$work/intel.txt" | head; exit 1
fi

/usr/bin/python3 - "$work/clean.bag" "$work/faulty.bag" <<'PY'
import math, sys
import rosbag, rospy
source, target = sys.argv[1], sys.argv[2]
with rosbag.Bag(source) as bag_in, rosbag.Bag(target, "w") as bag_out:
    start = bag_in.get_start_time()
    scans = 0
    previous_stamp = None
    for topic, msg, t in bag_in.read_messages():
        rel = t.to_sec() - start
        if topic == "/tf" and 20.0 <= rel < 25.0:
            continue  # 5 s without odom -> base_link
        if topic == "/scan":
            scans += 1
            if scans == 50:
                msg.header.stamp = msg.header.stamp - rospy.Duration(1.0)
            elif scans == 60:
                msg.header.stamp = previous_stamp
            elif scans == 70:
                msg.header.frame_id = "ghost_laser"
            elif scans == 80:
                msg.ranges = [float("nan")] * len(msg.ranges)
            previous_stamp = msg.header.stamp
        if topic == "/odom" and 30.0 <= rel < 31.0:
            msg.pose.pose.position.x = float("nan")  # a broken driver (SLAM reads tf)
        bag_out.write(topic, msg, t)
PY

status=0
"$bin/validate_bag" "$work/faulty.bag" >"$work/faulty.txt" || status=$?
cat "$work/faulty.txt" | grep PROBLEM || true
[ "$status" -eq 1 ] || { echo "FAIL: exit status $status for the faulty bag, expected 1"; exit 1; }
for expected in "/scan: 1 stamp(s) older" "/scan: 1 repeated stamp" "frame 'ghost_laser' is not connected" \
    "/scan: 181 NaN" "/scan: messages in several frames" "tf odom -> base_link: 1 gap(s)" \
    "/odom: " "message(s) with a non-finite pose or twist"; do
  grep -qF "$expected" "$work/faulty.txt" || { echo "FAIL: '$expected' not reported"; exit 1; }
done
echo "PASS"
