#!/usr/bin/env bash
# benchmarks/node_replay end to end on the Intel slice (laser config, played at 20x): one row
# with the offline and live update counts, both positive, and the node's busy shares from
# /diagnostics; bad arguments (a missing bag, a rate that is not positive, a bag without sensor
# topics) exit 1 naming them. No figure is asserted: how many frames the node keeps up with
# depends on the machine (docs/results.md, "Timing", has the measured ones).
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
source "$(dirname "$0")/lib/expect.sh"
require_tools offline_slam rbpf_slam_node
replay="$root/benchmarks/node_replay"
status=0

expect "missing bag" 1 'nonexistent.bag: no such file' \
  "$replay" "$work/nonexistent.bag" --bin-dir "$bin"
expect "rate not positive" 1 '--rate 0,2: every rate must be positive' \
  "$replay" "$root/test/data/intel_head.bag" --rate 0,2 --bin-dir "$bin"
/usr/bin/python3 - "$work/empty.bag" <<'PY'
import sys, rosbag
from std_msgs.msg import String
with rosbag.Bag(sys.argv[1], "w") as b:
    b.write("/chatter", String(data="x"))
PY
expect "no sensor topic" 1 'has no /features, /scan, /sonar or /sonar_cloud' \
  "$replay" "$work/empty.bag" --bin-dir "$bin"

"$replay" "$root/test/data/intel_head.bag" --rate 20 --bin-dir "$bin" >"$work/rows" 2>&1 || {
  echo "FAIL: node_replay exited $?"; cat "$work/rows"; exit 1; }
cat "$work/rows"
if /usr/bin/python3 - "$work/rows" <<'PY'
import sys
rows = [l.split(" | ") for l in open(sys.argv[1]) if l.startswith("intel_head.bag")]
assert len(rows) == 1, rows
r = rows[0]
assert r[1] == "laser_fastslam2.yaml" and r[2] == "20", r
offline, node = int(r[3]), int(r[4])
assert offline > 0 and node > 0, (offline, node)
assert all(0 <= int(x) for x in r[6].split(" / ")), r[6]  # the node reported busy shares
PY
then
  echo "ok: one row, offline and node updates positive"
else
  echo "FAIL: the row is not as expected"; status=1
fi
exit $status
