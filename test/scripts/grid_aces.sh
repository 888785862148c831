#!/usr/bin/env bash
# ACES laser slice (test/data/aces_head.bag, 150 scans): grid_pf (config/grid_pf_laser.yaml)
# maps it with offline_slam, which must save map.pgm + map.yaml in map_server conventions; the
# same scans rendered at the reference poses with the same inverse sensor model (render_grid,
# aligned to the run's map frame) are the yardstick. Fails unless the SLAM map's occupied-cell
# count is within 35% of the reference's, its free-space ratio free / (free + occupied) within
# 0.03, and its walls coincide: at least 60% of its occupied cells lie within 30 cm of a
# reference wall cell and 60% of the reference wall cells within 30 cm of one of its own. The
# same checks must FAIL for a bent map (the bag's odometry with 0.02 rad of extra heading drift
# per metre, rendered the same way), so that they can tell a bad map. The plain odometry map is
# reported too (on this slice the odometry drifts little: it is not a pass/fail case).
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools offline_slam render_grid
echo "work: $work"
config="$root/config/grid_pf_laser.yaml"
bag="$root/test/data/aces_head.bag"
ref="$root/test/data/aces_head.ref.tum"

"$bin/offline_slam" --bag "$bag" --config "$config" --output "$work/slam" --no-progress \
  --reference "$ref" >/dev/null
for f in map.pgm map.yaml map.png summary.json; do
  [ -s "$work/slam/$f" ] || { echo "FAIL: offline_slam wrote no $f"; exit 1; }
done
"$bin/render_grid" --bag "$bag" --reference "$ref" --config "$config" --output "$work/ref" \
  --align-to "$work/slam/trajectory.tum" >/dev/null
# The negative control: odometry (tf odom -> base_link at each scan) rendered the same way.
/usr/bin/python3 - "$bag" "$work/odom.tum" "$work/bent.tum" <<'PY'
import bisect, math, sys, rosbag
bag, out, bent_out = sys.argv[1], sys.argv[2], sys.argv[3]
odom, scans = [], []
with rosbag.Bag(bag) as b:
    for topic, msg, _ in b.read_messages(topics=["/tf", "/scan"]):
        if topic == "/scan":
            scans.append(msg.header.stamp.to_sec())
            continue
        for t in msg.transforms:
            if t.child_frame_id.strip("/") == "base_link":
                q = t.transform.rotation
                odom.append((t.header.stamp.to_sec(), t.transform.translation.x,
                             t.transform.translation.y, q.z, q.w))
odom.sort()
times = [o[0] for o in odom]
poses = []
for s in scans:
    j = bisect.bisect_left(times, s)
    i = min(range(max(0, j - 1), min(len(odom), j + 1)), key=lambda k: abs(times[k] - s))
    _, x, y, qz, qw = odom[i]
    poses.append((s, x, y, 2.0 * math.atan2(qz, qw)))
with open(out, "w") as f:
    for s, x, y, a in poses:
        f.write("%.6f %.6f %.6f 0 0 0 %.9f %.9f\n" % (s, x, y, math.sin(a / 2), math.cos(a / 2)))
# Bent: the same increments with extra heading drift per metre travelled.
with open(bent_out, "w") as f:
    bx, by, ba = poses[0][1], poses[0][2], poses[0][3]
    for k, (s, x, y, a) in enumerate(poses):
        if k > 0:
            _, px, py, pa = poses[k - 1]
            c, sn = math.cos(pa), math.sin(pa)
            dx, dy = c * (x - px) + sn * (y - py), -sn * (x - px) + c * (y - py)
            da = a - pa
            bx += math.cos(ba) * dx - math.sin(ba) * dy
            by += math.sin(ba) * dx + math.cos(ba) * dy
            ba += da + 0.02 * math.hypot(dx, dy)
        f.write("%.6f %.6f %.6f 0 0 0 %.9f %.9f\n" % (s, bx, by, math.sin(ba / 2), math.cos(ba / 2)))
PY
for control in odom bent; do
  "$bin/render_grid" --bag "$bag" --reference "$work/$control.tum" --config "$config" \
    --output "$work/$control" --align-to "$work/slam/trajectory.tum" >/dev/null
done

/usr/bin/python3 - "$work" <<'PY'
import sys
import numpy as np
import yaml

work = sys.argv[1]

def load(prefix):
    meta = yaml.safe_load(open(prefix + ".yaml"))
    with open(prefix + ".pgm", "rb") as f:
        data = f.read()
    fields, pos = [], 0
    while len(fields) < 4:  # P5 width height maxval, comments skipped
        end = data.index(b"\n", pos)
        line = data[pos:end]
        pos = end + 1
        if not line.startswith(b"#"):
            fields += line.split()
    w, h = int(fields[1]), int(fields[2])
    img = np.frombuffer(data[pos:pos + w * h], dtype=np.uint8).reshape(h, w)[::-1]  # row 0 = min y
    return img, meta["resolution"], meta["origin"]

def world_cells(prefix, value):
    img, res, origin = load(prefix)
    ys, xs = np.nonzero(img == value)
    return np.stack([origin[0] + (xs + 0.5) * res, origin[1] + (ys + 0.5) * res], 1), res

def stats(prefix):
    img, _, _ = load(prefix)
    occupied, free = int((img == 0).sum()), int((img == 254).sum())
    return occupied, free, free / float(free + occupied)

def near_fraction(a, b, radius, res):
    """Fraction of points a within radius of some point of b (grid hashing of b)."""
    cells = set(map(tuple, np.floor(b / res).astype(np.int64)))
    k = int(np.ceil(radius / res))
    ia = np.floor(a / res).astype(np.int64)
    hits = 0
    for x, y in ia:
        if any((x + dx, y + dy) in cells for dx in range(-k, k + 1) for dy in range(-k, k + 1)):
            hits += 1
    return hits / float(max(len(a), 1))

def check(name, prefix, reference):
    occ, free, ratio = stats(prefix)
    r_occ, r_free, r_ratio = stats(reference)
    mine, res = world_cells(prefix, 0)
    theirs, _ = world_cells(reference, 0)
    precision = near_fraction(mine, theirs, 0.30, res)
    recall = near_fraction(theirs, mine, 0.30, res)
    ok = (abs(occ - r_occ) <= 0.35 * r_occ and abs(ratio - r_ratio) <= 0.03 and
          precision >= 0.60 and recall >= 0.60)
    print("%s: occupied %d (reference %d), free ratio %.3f (reference %.3f), walls within 30 cm: "
          "%.2f of its own, %.2f of the reference's -> %s"
          % (name, occ, r_occ, ratio, r_ratio, precision, recall, "pass" if ok else "fail"))
    return ok

slam_ok = check("grid_pf", work + "/slam/map", work + "/ref")
check("odometry (for information)", work + "/odom", work + "/ref")
bent_ok = check("bent odometry (negative control)", work + "/bent", work + "/ref")
if not slam_ok:
    print("FAIL: the grid_pf map does not match the reference rendering"); sys.exit(1)
if bent_ok:
    print("FAIL: the bent map passes too: the checks cannot tell a bad map"); sys.exit(1)
print("PASS")
PY
