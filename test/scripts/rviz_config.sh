#!/usr/bin/env bash
# rviz config test: starts Xvfb, sim.launch (sim_node + rbpf_slam_node + rviz with
# rviz/rbpf_slam.rviz) on worlds/test_small.yaml for ~25 s, takes a screenshot of the virtual
# screen and fails when rviz died, logged an error (a display plugin that does not load, a bad
# config) or the screenshot is blank. The screenshot is kept in build/test_output/.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
out="${RBPF_TEST_OUTPUT:-$root/build/test_output}"
mkdir -p "$out"
for tool in rviz Xvfb import roslaunch; do
  command -v "$tool" >/dev/null || { echo "FAIL: $tool not installed (scripts/common.sh installs it)"; exit 1; }
done

work=$(mktemp -d)
pids=()
cleanup() {
  for pid in "${pids[@]+"${pids[@]}"}"; do kill -INT "$pid" 2>/dev/null || true; done
  sleep 3
  for pid in "${pids[@]+"${pids[@]}"}"; do kill -KILL "$pid" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT

# A display and a master port of our own, so that parallel runs do not meet.
number=$((100 + $$ % 400))
port=$((20000 + $$ % 20000))
Xvfb ":$number" -screen 0 1280x1024x24 -nolisten tcp >"$work/xvfb.log" 2>&1 &
pids+=($!)
sleep 2
export DISPLAY=":$number" LIBGL_ALWAYS_SOFTWARE=1
export ROS_MASTER_URI="http://localhost:$port" ROS_LOG_DIR="$work/log"
roslaunch -p "$port" --screen rbpf_slam sim.launch \
  world:="$root/worlds/test_small.yaml" rate:=2 >"$work/launch.log" 2>&1 &
launch=$!
pids=("$launch" "${pids[@]}")
sleep 25
if ! kill -0 "$launch" 2>/dev/null; then
  echo "FAIL: sim.launch exited early"; tail -n 30 "$work/launch.log"; exit 1
fi
rviz_alive=$(pgrep -P "$launch" -f "rviz" || true)
import -window root "$out/rviz_screenshot.png"
kill -INT "$launch"
wait "$launch" || true

status=0
if [ -z "$rviz_alive" ]; then
  echo "FAIL: rviz was not running after 25 s"; status=1
fi
# rviz reports plugins and config problems as [ERROR] lines on its console (--screen).
if grep -E "^\[ERROR\]|\[ERROR\] \[" "$work/launch.log" | grep -v "shutting down" >"$work/errors.txt"; then
  echo "FAIL: errors in the launch output:"; cat "$work/errors.txt"; status=1
fi
colours=$(convert "$out/rviz_screenshot.png" -format "%k" info:)
echo "screenshot $out/rviz_screenshot.png: $colours colours"
if [ "$colours" -lt 10 ]; then
  echo "FAIL: the screenshot is blank"; status=1
fi
[ "$status" -eq 0 ] && echo "PASS"
exit "$status"
