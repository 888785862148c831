#!/usr/bin/env bash
# grid_pf's grid grows while mapping (grid.max_size_m): on the simulated e-puck world a grid
# that starts at 0.4 m x 0.4 m must give exactly the trajectory of config/grid_pf.yaml's 3 m
# grid (growth keeps the cell lattice, so no cell moves); the same small grid fixed
# (max_size_m 0) must report the updates outside it, and one that may grow to 0.8 m only the
# updates it could not grow for, each named in offline_slam's summary. render_grid (the
# reference rendering of grid_aces.sh) grows the same way: the ACES slice rendered on a 20 m
# first extent must give the 120 m grid's cells, and on a fixed 20 m grid name its scans beyond.
# A first extent smaller than the sensor's reach (the sonar room's 3 m cones on a 1 m grid)
# loses the far echoes: they must be counted and named (readings_beyond_reach).
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam render_grid

"$bin/simulate" --world "$root/worlds/yatim_epuck.yaml" --output "$work/sim.bag" --seed 1 >/dev/null
run() {  # NAME [--set ...]
  local name=$1
  shift
  "$bin/offline_slam" --bag "$work/sim.bag" --config "$root/config/grid_pf.yaml" \
    --output "$work/$name" --no-progress "$@" >"$work/$name.log" 2>&1 ||
    { echo "FAIL: offline_slam ($name)"; cat "$work/$name.log"; exit 1; }
}
small=(--set grid.size_x_m=0.4 --set grid.size_y_m=0.4)
run shipped --output-bag "$work/shipped.bag"
run grown "${small[@]}"
run fixed "${small[@]}" --set grid.max_size_m=0
run capped "${small[@]}" --set grid.max_size_m=0.8

status=0
if cmp -s "$work/shipped/trajectory.tum" "$work/grown/trajectory.tum"; then
  echo "ok: the grown 0.4 m grid gives the 3 m grid's trajectory ($(wc -l <"$work/shipped/trajectory.tum") poses)"
else
  echo "FAIL: the grown grid's trajectory differs from the 3 m grid's"; status=1
fi
/usr/bin/python3 - "$work" <<'PY' || status=1
import json, os, sys
work = sys.argv[1]
s = {n: json.load(open(os.path.join(work, n, "summary.json"))) for n in ("shipped", "grown", "fixed", "capped")}
log = {n: open(os.path.join(work, n + ".log")).read() for n in s}
fails = []
for n in ("shipped", "grown"):
    if s[n]["updates_outside_grid"] or s[n]["grid_growth_refused"]:
        fails.append("%s: %d outside, %d refused" % (n, s[n]["updates_outside_grid"], s[n]["grid_growth_refused"]))
if s["grown"]["map_occupied_cells"] != s["shipped"]["map_occupied_cells"]:
    fails.append("grown map %d occupied cells, shipped %d" % (s["grown"]["map_occupied_cells"], s["shipped"]["map_occupied_cells"]))
if not s["fixed"]["updates_outside_grid"] > 0 or "outside the grid" not in log["fixed"]:
    fails.append("the fixed grid's updates outside it are not reported")
if not s["capped"]["grid_growth_refused"] > 0 or "could not grow" not in log["capped"]:
    fails.append("the capped grid's refused growth is not reported")
if not s["capped"]["map_width"] * s["capped"]["map_resolution"] <= 0.8 + 0.16 + 1e-9:
    fails.append("the capped grid is %.2f m wide" % (s["capped"]["map_width"] * s["capped"]["map_resolution"]))
import rosbag
with rosbag.Bag(os.path.join(work, "shipped.bag")) as bag:
    counts = {t: i.message_count for t, i in bag.get_type_and_topic_info().topics.items()}
print("--output-bag: %s ~map, %s ~landmarks" % (counts.get("/rbpf_slam_node/map"), counts.get("/rbpf_slam_node/landmarks")))
if not counts.get("/rbpf_slam_node/map", 0) >= 2 or "/rbpf_slam_node/landmarks" in counts:
    fails.append("--output-bag: grid_pf's map is not written every 30 s and at the end, or empty landmark markers are")
print("map occupied cells: shipped %d, grown %d, fixed %d, capped %d; outside: fixed %d, capped %d; refused: capped %d"
      % (s["shipped"]["map_occupied_cells"], s["grown"]["map_occupied_cells"], s["fixed"]["map_occupied_cells"],
         s["capped"]["map_occupied_cells"], s["fixed"]["updates_outside_grid"], s["capped"]["updates_outside_grid"],
         s["capped"]["grid_growth_refused"]))
for f in fails:
    print("FAIL: " + f)
sys.exit(1 if fails else 0)
PY
"$bin/simulate" --world "$root/worlds/lee_sonar_room.yaml" --output "$work/room.bag" --seed 1 \
  --duration 60 >/dev/null
for size in 30 1; do
  "$bin/offline_slam" --bag "$work/room.bag" --config "$root/config/grid_pf_sonar.yaml" \
    --output "$work/room$size" --no-progress --set grid.size_x_m=$size --set grid.size_y_m=$size \
    >"$work/room$size.log" 2>&1 || { echo "FAIL: offline_slam (room, $size m)"; cat "$work/room$size.log"; exit 1; }
done
/usr/bin/python3 - "$work" <<'PY' || status=1
import json, os, sys
work = sys.argv[1]
n = {s: json.load(open(os.path.join(work, "room%d" % s, "summary.json")))["readings_beyond_reach"] for s in (30, 1)}
named = "beyond the diagonal of the first extent" in open(os.path.join(work, "room1.log")).read()
print("sonar room, readings beyond the grid's reach: 30 m first extent %d, 1 m %d (named: %s)" % (n[30], n[1], named))
sys.exit(0 if n[30] == 0 and n[1] > 0 and named else "FAIL: readings beyond the reach not counted or not named")
PY
render() {  # NAME [--set ...]: render_grid's JSON line
  local name=$1
  shift
  "$bin/render_grid" --bag "$root/test/data/aces_head.bag" --reference "$root/test/data/aces_head.ref.tum" \
    --config "$root/config/grid_pf_laser.yaml" --output "$work/$name" "$@" 2>"$work/$name.err" ||
    { echo "FAIL: render_grid ($name)"; cat "$work/$name.err"; exit 1; }
}
render big >"$work/big.json"
render small --set grid.size_x_m=20 --set grid.size_y_m=20 >"$work/small.json"
render fixed --set grid.size_x_m=20 --set grid.size_y_m=20 --set grid.max_size_m=0 >"$work/fixed.json"
/usr/bin/python3 - "$work" <<'PY' || status=1
import json, os, sys
r = {n: json.load(open(os.path.join(sys.argv[1], n + ".json"))) for n in ("big", "small", "fixed")}
print("render_grid occupied cells: 120 m %d, 20 m growing %d, 20 m fixed %d (%d scans beyond it)"
      % (r["big"]["occupied_cells"], r["small"]["occupied_cells"], r["fixed"]["occupied_cells"],
         r["fixed"]["scans_beyond_the_grid"]))
ok = (r["small"]["occupied_cells"] == r["big"]["occupied_cells"] and r["small"]["free_cells"] == r["big"]["free_cells"]
      and r["small"]["scans_beyond_the_grid"] == 0 and r["fixed"]["scans_beyond_the_grid"] > 0)
sys.exit(0 if ok else "FAIL: render_grid does not grow as the filter does")
PY
[ "$status" -eq 0 ] && echo "PASS"
exit "$status"
