#!/usr/bin/env bash
# Soak: rbpf_slam_node maps a looping bag (rosbag play -l --clock, worlds/test_small.yaml
# simulated at test time) for SOAK_SIM_MINUTES (default 30) minutes of simulated time at
# SOAK_RATE (default 20) times real time, while its resident memory is sampled from /proc.
# Fails unless the node is alive at the end, cleared its map at every loop of the bag (one
# reset per loop: a map that freezes after a loop is a classic failure) and its RSS grew by
# less than 2 MB per hour of data between the second and the last quarter of the run (peak
# against peak, so that the map's own size within a loop does not count).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
bin="${RBPF_BIN:-$root/build/devel/lib/rbpf_slam}"
[ -x "$bin/simulate" ] && [ -x "$bin/rbpf_slam_node" ] || { echo "FAIL: not built ($bin)"; exit 1; }
sim_minutes=${SOAK_SIM_MINUTES:-30}
rate=${SOAK_RATE:-20}
source "$here/lib/launch.sh"

"$bin/simulate" --world "$root/worlds/test_small.yaml" --output "$work/loop.bag" --seed 5 >/dev/null
bag_s=$(/usr/bin/python3 -c "
import rosbag, sys
b = rosbag.Bag(sys.argv[1]); print(b.get_end_time() - b.get_start_time())" "$work/loop.bag")

cat >"$work/soak.launch" <<LAUNCH
<launch>
  <param name="use_sim_time" value="true"/>
  <node pkg="rosbag" type="play" name="player" args="--clock --loop --quiet --rate=$rate $work/loop.bag"/>
  <node pkg="rbpf_slam" type="rbpf_slam_node" name="rbpf_slam_node" output="screen">
    <rosparam command="load" file="$root/config/laser_fastslam2.yaml"/>
  </node>
</launch>
LAUNCH

start_launch "$work/soak.launch" "$work/launch.log"
node=$(child_pid rbpf_slam_node)
[ -n "$node" ] || { echo "FAIL: rbpf_slam_node did not start"; tail -n 30 "$work/launch.log"; exit 1; }

wall_s=$(/usr/bin/python3 -c "print(int($sim_minutes * 60 / $rate) + 5)")
echo "soak: ${sim_minutes} min of data at ${rate}x (${wall_s} s wall), bag ${bag_s} s per loop, node pid $node"
start=$(date +%s.%N)
: >"$work/rss.txt"
while :; do
  now=$(date +%s.%N)
  elapsed=$(/usr/bin/python3 -c "print($now - $start)")
  /usr/bin/python3 -c "import sys; sys.exit(0 if $elapsed < $wall_s else 1)" || break
  if ! kill -0 "$node" 2>/dev/null; then
    echo "FAIL: rbpf_slam_node died"; tail -n 30 "$work/launch.log"; exit 1
  fi
  rss=$(awk '/^VmRSS:/ {print $2}' "/proc/$node/status")
  echo "$elapsed $rss" >>"$work/rss.txt"
  sleep 1
done
kill -0 "$node" 2>/dev/null || { echo "FAIL: rbpf_slam_node died"; exit 1; }
resets=$(grep -c "time jumped back" "$work/launch.log" || true)

/usr/bin/python3 - "$work/rss.txt" "$rate" "$bag_s" "$resets" <<'PY'
import sys
rows = [tuple(map(float, l.split())) for l in open(sys.argv[1]) if l.strip()]
rate, bag_s, resets = float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
end = rows[-1][0]
def peak(lo, hi):
    return max(r for t, r in rows if lo * end <= t < hi * end)
early, late = peak(0.25, 0.5), peak(0.75, 1.0)
hours = 0.5 * end * rate / 3600.0  # data between the two windows' midpoints
growth = (late - early) / 1024.0 / hours
loops = end * rate / bag_s
print("RSS peak %.1f MB (2nd quarter) -> %.1f MB (last quarter): %+.2f MB per hour of data; "
      "%d resets for ~%.1f loops of the bag" % (early / 1024, late / 1024, growth, resets, loops))
ok = True
if growth >= 2.0:
    print("FAIL: memory grows by %.2f MB per hour of data (limit 2)" % growth); ok = False
if resets < int(0.7 * loops) - 1:
    print("FAIL: %d map resets for ~%.1f loops: the node did not restart at each loop" % (resets, loops)); ok = False
if resets < 1:
    print("FAIL: no reset at all"); ok = False
print("PASS" if ok else "FAIL")
sys.exit(0 if ok else 1)
PY
