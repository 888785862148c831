#!/usr/bin/env bash
# A laser mounted upside down (its frame rolled by pi on tf, the beams reversed so that they
# see the same world) whose scans name their frame "/laser" (old drivers): offline_slam must
# give the same path as on the original bag. Before session 12 the scan was mirrored (the beam
# angles kept their sign) and, live, "/laser" was dropped as a frame tf does not know.
# A laser pitched by 10 deg is used as if level: offline_slam must say so (stderr and
# summary.json's tilted_frames), and must not say it of the level or upside-down mounts.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam

"$bin/simulate" --world "$root/worlds/laser_office.yaml" --output "$work/level.bag" --seed 3 \
  --duration 90 >/dev/null
/usr/bin/python3 "$root/test/tools/remount_laser.py" "$work/level.bag" "$work/flipped.bag"
/usr/bin/python3 "$root/test/tools/remount_laser.py" --pitch-deg 10 "$work/level.bag" \
  "$work/tilted.bag"
for bag in level flipped tilted; do
  "$bin/offline_slam" --bag "$work/$bag.bag" --config "$root/config/laser_fastslam2.yaml" \
    --reference "$work/level.ref.tum" --output "$work/$bag" --seed 1 --no-progress \
    >"$work/$bag.log" 2>&1 || { echo "FAIL: offline_slam on $bag.bag"; cat "$work/$bag.log"; exit 1; }
done
/usr/bin/python3 - "$work/level/summary.json" "$work/flipped/summary.json" \
  "$work/tilted/summary.json" "$work/tilted.log" "$work/level.log" <<'PY'
import json, sys
level, flipped, tilted = (json.load(open(p)) for p in sys.argv[1:4])
tilted_log, level_log = (open(p).read() for p in sys.argv[4:6])
print("level: ATE %.3f m, %d updates, %d landmarks; upside down: ATE %.3f m, %d updates, %d landmarks"
      % (level["ate_rmse_m"], level["updates"], level["landmarks"],
         flipped["ate_rmse_m"], flipped["updates"], flipped["landmarks"]))
problems = []
if flipped["updates"] != level["updates"]:
    problems.append("updates differ (frames dropped?)")
if not flipped["ate_rmse_m"] < max(0.3, 2.0 * level["ate_rmse_m"]):
    problems.append("the upside-down laser's ATE is far worse (a mirrored scan?)")
print("tilted 10 deg: tilted_frames %s, ATE %.3f m" % (tilted.get("tilted_frames"),
                                                     tilted["ate_rmse_m"]))
if level.get("tilted_frames") != 0 or flipped.get("tilted_frames") != 0:
    problems.append("a level or upside-down laser was reported as tilted")
if tilted.get("tilted_frames") != 1:
    problems.append("the laser pitched by 10 deg is not reported in tilted_frames")
if "is tilted 10.0 deg from level" not in tilted_log or "tilted" in level_log:
    problems.append("no (or a wrong) tilt warning on stderr")
if problems:
    print("FAIL: " + "; ".join(problems))
    sys.exit(1)
PY
echo PASS
