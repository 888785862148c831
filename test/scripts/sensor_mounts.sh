#!/usr/bin/env bash
# A laser mounted upside down (its frame rolled by pi on tf, the beams reversed so that they
# see the same world) whose scans name their frame "/laser" (old drivers): offline_slam must
# give the same path as on the original bag. Before session 12 the scan was mirrored (the beam
# angles kept their sign) and, live, "/laser" was dropped as a frame tf does not know.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam

"$bin/simulate" --world "$root/worlds/laser_office.yaml" --output "$work/level.bag" --seed 3 \
  --duration 90 >/dev/null
/usr/bin/python3 "$root/test/tools/remount_laser.py" "$work/level.bag" "$work/flipped.bag"
for bag in level flipped; do
  "$bin/offline_slam" --bag "$work/$bag.bag" --config "$root/config/laser_fastslam2.yaml" \
    --reference "$work/level.ref.tum" --output "$work/$bag" --seed 1 --no-progress \
    >"$work/$bag.log" 2>&1 || { echo "FAIL: offline_slam on $bag.bag"; cat "$work/$bag.log"; exit 1; }
done
/usr/bin/python3 - "$work/level/summary.json" "$work/flipped/summary.json" <<'PY'
import json, sys
level, flipped = (json.load(open(p)) for p in sys.argv[1:3])
print("level: ATE %.3f m, %d updates, %d landmarks; upside down: ATE %.3f m, %d updates, %d landmarks"
      % (level["ate_rmse_m"], level["updates"], level["landmarks"],
         flipped["ate_rmse_m"], flipped["updates"], flipped["landmarks"]))
problems = []
if flipped["updates"] != level["updates"]:
    problems.append("updates differ (frames dropped?)")
if not flipped["ate_rmse_m"] < max(0.3, 2.0 * level["ate_rmse_m"]):
    problems.append("the upside-down laser's ATE is far worse (a mirrored scan?)")
if problems:
    print("FAIL: " + "; ".join(problems))
    sys.exit(1)
PY
echo PASS
