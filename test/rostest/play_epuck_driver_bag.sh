#!/usr/bin/env bash
# For rostests: simulates the e-puck world into a fresh bag, rewrites it the way the e-puck's ROS
# driver publishes (test/tools/epuck_driver_bag.py --driver-ranges --driver-tf: /proximity0 .. 7, frames
# NAME/base_link and NAME/base_prox0 .. 7, the driver's 5 cm range), then plays it with --clock.
#   play_epuck_driver_bag.sh SEED OUT_DIR RATE NAME [DURATION_S]
# Writes OUT_DIR/reference.tum (ground truth) once the bag is complete; the test node waits for it.
set -euo pipefail
args=()
for a in "$@"; do
  case "$a" in __*:=*) ;; *) args+=("$a") ;; esac  # roslaunch's own arguments
done
if [ ${#args[@]} -lt 4 ]; then
  echo "usage: play_epuck_driver_bag.sh SEED OUT_DIR RATE NAME [DURATION_S]" >&2
  exit 2
fi
seed=${args[0]} out=${args[1]} rate=${args[2]} name=${args[3]} duration=${args[4]:-0}
root=$(cd "$(dirname "$0")/../.." && pwd)
rm -rf "$out"
mkdir -p "$out"
rosrun rbpf_slam simulate --world "$root/worlds/yatim_epuck.yaml" --output "$out/sim.bag" \
  --seed "$seed" --duration "$duration"
python3 "$root/test/tools/epuck_driver_bag.py" "$out/sim.bag" "$out/driver.bag" --name "$name" \
  --driver-ranges --driver-tf
mv "$out/sim.ref.tum" "$out/reference.tum"
exec rosbag play --clock --quiet --delay=3 --rate="$rate" "$out/driver.bag"
