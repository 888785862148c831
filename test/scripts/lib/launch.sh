# Shared by script tests that run ROS nodes: a work directory and a roslaunch of their own
# (own master port, logs in the work directory), stopped and removed on exit.
#   source "$here/lib/launch.sh"
#   start_launch FILE.launch LOG      # sets $launch (roslaunch's pid), exports ROS_* for it
#   node=$(child_pid rbpf_slam_node)  # a node started by that roslaunch (not a namesake)
# KEEP_WORK=1 keeps $work for inspection.

work=$(mktemp -d)
launch=""
cleanup() {
  if [ -n "$launch" ] && kill -0 "$launch" 2>/dev/null; then
    kill -INT "$launch" 2>/dev/null || true
    for _ in $(seq 1 20); do kill -0 "$launch" 2>/dev/null || break; sleep 0.5; done
    kill -KILL "$launch" 2>/dev/null || true
  fi
  [ -n "${KEEP_WORK:-}" ] && echo "work directory kept: $work" || rm -rf "$work"
}
trap cleanup EXIT

start_launch() {
  local file=$1 log=$2
  local port=$((20000 + ($$ + RANDOM) % 20000))
  export ROS_MASTER_URI="http://localhost:$port" ROS_LOG_DIR="$work/log" ROS_HOME="$work/home"
  roslaunch -p "$port" --screen "$file" >"$log" 2>&1 &
  launch=$!
}

# Waits up to 30 s for a child of our roslaunch whose command line matches $1; prints its pid.
child_pid() {
  local pid=""
  for _ in $(seq 1 60); do
    pid=$(pgrep -P "$launch" -f "$1" | head -n 1 || true)
    [ -n "$pid" ] && break
    sleep 0.5
  done
  echo "$pid"
}
