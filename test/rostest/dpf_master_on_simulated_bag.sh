#!/usr/bin/env bash
# For rostests: simulates a world into a fresh bag, then runs dpf_master_node on it (bag mode).
#   dpf_master_on_simulated_bag.sh WORLD SEED OUT_DIR DURATION_S [__name:=... other ROS args]
# Writes OUT_DIR/sim.bag, OUT_DIR/reference.tum and the master's results in OUT_DIR/master/
# (dpf_master.done last). roslaunch's own arguments are passed on to the node, so the node's
# private parameters from the launch file apply.
set -euo pipefail
args=() ros_args=()
for a in "$@"; do
  case "$a" in __*:=*) ros_args+=("$a") ;; *) args+=("$a") ;; esac
done
if [ ${#args[@]} -lt 4 ]; then
  echo "usage: dpf_master_on_simulated_bag.sh WORLD SEED OUT_DIR DURATION_S" >&2
  exit 2
fi
world=${args[0]} seed=${args[1]} out=${args[2]} duration=${args[3]}
rm -rf "$out"
mkdir -p "$out/master"
rosrun rbpf_slam simulate --world "$world" --output "$out/sim.bag" --seed "$seed" \
  --duration "$duration"
mv "$out/sim.ref.tum" "$out/reference.tum"
exec rosrun rbpf_slam dpf_master_node _bag:="$out/sim.bag" _output:="$out/master" \
  "${ros_args[@]}"
