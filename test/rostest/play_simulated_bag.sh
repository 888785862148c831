#!/usr/bin/env bash
# For rostests: simulates a world into a fresh bag at test time, then plays it with --clock.
#   play_simulated_bag.sh WORLD SEED OUT_DIR RATE [DURATION_S]
# Writes OUT_DIR/sim.bag, OUT_DIR/sim.landmarks.yaml and, once the bag is complete,
# OUT_DIR/reference.tum (ground truth), which the test node waits for. roslaunch's own
# arguments (__name:=..., __log:=...) are ignored.
set -euo pipefail
args=()
for a in "$@"; do
  case "$a" in __*:=*) ;; *) args+=("$a") ;; esac
done
if [ ${#args[@]} -lt 4 ]; then
  echo "usage: play_simulated_bag.sh WORLD SEED OUT_DIR RATE [DURATION_S]" >&2
  exit 2
fi
world=${args[0]} seed=${args[1]} out=${args[2]} rate=${args[3]} duration=${args[4]:-0}
rm -rf "$out"
mkdir -p "$out"
rosrun rbpf_slam simulate --world "$world" --output "$out/sim.bag" --seed "$seed" \
  --duration "$duration"
mv "$out/sim.ref.tum" "$out/reference.tum"
exec rosbag play --clock --quiet --delay=3 --rate="$rate" "$out/sim.bag"
