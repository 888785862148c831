#!/usr/bin/env bash
# For rostests: simulates a world into a fresh bag at test time, then plays it with --clock.
#   play_simulated_bag.sh WORLD SEED OUT_DIR RATE [DURATION_S [READY_FILE]]
# Writes OUT_DIR/sim.bag, OUT_DIR/sim.landmarks.yaml and, once the bag is complete,
# OUT_DIR/reference.tum (ground truth), which the test node waits for. With READY_FILE it then
# waits (up to 60 s) for that file before playing: the test node writes it once it has asked
# the node under test for what must come before the first frame (~global_localization).
# roslaunch's own arguments (__name:=..., __log:=...) are ignored.
set -euo pipefail
args=()
for a in "$@"; do
  case "$a" in __*:=*) ;; *) args+=("$a") ;; esac
done
if [ ${#args[@]} -lt 4 ]; then
  echo "usage: play_simulated_bag.sh WORLD SEED OUT_DIR RATE [DURATION_S [READY_FILE]]" >&2
  exit 2
fi
world=${args[0]} seed=${args[1]} out=${args[2]} rate=${args[3]} duration=${args[4]:-0}
ready=${args[5]:-}
rm -rf "$out"
mkdir -p "$out"
rosrun rbpf_slam simulate --world "$world" --output "$out/sim.bag" --seed "$seed" \
  --duration "$duration"
mv "$out/sim.ref.tum" "$out/reference.tum"
if [ -n "$ready" ]; then
  for _ in $(seq 600); do
    [ -e "$ready" ] && break
    sleep 0.1
  done
  [ -e "$ready" ] || echo "play_simulated_bag.sh: $ready did not appear in 60 s; playing" >&2
fi
exec rosbag play --clock --quiet --delay=3 --rate="$rate" "$out/sim.bag"
