#!/usr/bin/env bash
# benchmarks/plot_results on two small hand-made run_experiments outputs: both figures are
# written as PNG images, and bad input (a world one file lacks, two configs in one file, a run
# whose trajectory is missing, a NaN in a trajectory, an output directory that does not exist)
# exits 1 with a message naming it (a bad option: 2, the usage).
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
source "$(dirname "$0")/lib/expect.sh"
plot="$root/benchmarks/plot_results"
status=0

# make_runs OUT CONFIG OFFSET: results.json with worlds w1 and w2, seeds 1-3, each run with a
# trajectory (the true square path shifted by OFFSET m) and three landmarks.
mkdir -p "$work/bags"
/usr/bin/python3 - "$work/bags" <<'PY'
import sys
bags = sys.argv[1]
for world in ("w1", "w2"):
    for seed in (1, 2, 3):
        stem = f"{bags}/{world}_seed{seed}"
        with open(stem + ".ref.tum", "w") as f:
            for i in range(40):
                x, y = (i, 0) if i < 20 else (20, i - 20)
                f.write(f"{i * 0.2:.1f} {x * 0.5} {y * 0.5} 0 0 0 0 1\n")
        with open(stem + ".landmarks.yaml", "w") as f:
            f.write("landmarks:\n  - {id: 0, x_m: 2, y_m: 1}\n"
                    "  - {id: 1, x_m: 6, y_m: -1, after_x_m: 6.5, after_y_m: -1}\n"
                    "objects:\n"
                    "  - {name: walls, shape: polygon, closed: true,"
                    " points: [[-1, -2], [11, -2], [11, 11], [-1, 11]]}\n"
                    "  - {name: table, shape: polygon, closed: true,"
                    " points: [[4, 3], [5, 3], [5, 4]], after_points: [[6, 3], [7, 3], [7, 4]]}\n"
                    "  - {name: box, shape: polyline, closed: false, removed: true,"
                    " points: [[8, 1], [9, 1]]}\n")
PY
make_runs() {
  /usr/bin/python3 - "$work" "$@" <<'PY'
import json, os, sys
work, out, config, offset = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
runs = []
for world in ("w1", "w2"):
    for seed in (1, 2, 3):
        run_dir = f"{work}/{out}/runs/{world}/{seed}"
        os.makedirs(run_dir)
        with open(f"{work}/bags/{world}_seed{seed}.ref.tum") as f, \
                open(run_dir + "/trajectory.tum", "w") as g:
            for line in f:
                v = line.split()
                g.write(f"{v[0]} {float(v[1]) + offset} {v[2]} 0 0 0 0 1\n")
        with open(run_dir + "/landmarks.yaml", "w") as g:
            g.write("landmarks:\n  - {id: 4, type: point, x: 2.1, y: 1.0}\n"
                    "  - {id: 5, type: point, x: 6.4, y: -1.1}\n"
                    "  - {id: 6, type: line, rho: 3, theta: 0}\n")
        runs.append({"world": world, "config": config, "seed": seed, "status": "ok",
                     "bag": f"{work}/bags/{world}_seed{seed}.bag", "run_dir": run_dir,
                     "final_position_error_m": 0.1 * seed + offset,
                     "point_landmarks": 3, "spurious_landmarks": seed % 2,
                     "duplicate_landmarks": 1, "landmark_error_m": 0.05 * seed})
json.dump({"runs": runs}, open(f"{work}/{out}/results.json", "w"))
PY
}
mkdir -p "$work/a" "$work/b"
make_runs a cfg_a 0.0
make_runs b cfg_b 0.3

expect "two figures" 0 "wrote .*fig_seeds.png, .*fig_map.png; the map draws 3 objects \(1 moved, 1 removed\)" \
  "$plot" "$work/a/results.json" "$work/b/results.json" --out "$work/fig" \
  --map-world w2 --map-seed 3
for png in fig_seeds fig_map; do
  if [ "$(head -c 8 "$work/$png.png" | od -An -tx1 | tr -d ' \n')" != "89504e470d0a1a0a" ] ||
     [ "$(stat -c %s "$work/$png.png")" -lt 10000 ]; then
    echo "FAIL: $png.png is not a PNG image of a plausible size"; status=1
  else
    echo "ok: $png.png is a PNG image ($(stat -c %s "$work/$png.png") bytes)"
  fi
done
expect "a world one file lacks" 1 "worlds \['w3'\] not run by both" \
  "$plot" "$work/a/results.json" "$work/b/results.json" --out "$work/x" --worlds w1,w3
expect "--map-world without --map-seed" 2 "go together" \
  "$plot" "$work/a/results.json" "$work/b/results.json" --out "$work/x" --map-world w1
# Variants of a/results.json: mixed.json (two configs), failed.json (no successful run) and
# gaps.json (a NaN landmark error, a missing key, a failed seed).
/usr/bin/python3 - "$work" <<'PY'
import json, sys
work = sys.argv[1]
runs = json.load(open(f"{work}/a/results.json"))["runs"]
def write(name, changed):
    json.dump({"runs": changed}, open(f"{work}/a/{name}.json", "w"))
write("mixed", [dict(runs[0], config="other")] + runs[1:])
write("failed", [dict(r, status="failed") for r in runs])
gaps = [dict(r) for r in runs]
gaps[0]["landmark_error_m"] = float("nan")  # a run without a matched landmark
del gaps[1]["duplicate_landmarks"]
gaps[2]["status"] = "failed"
write("gaps", gaps)
PY
expect "two configs in one file" 1 "holds configs \['cfg_a', 'other'\]; name one" \
  "$plot" "$work/a/mixed.json" "$work/b/results.json" --out "$work/x"
expect "one of two configs chosen" 0 "wrote .*chosen_seeds.png" \
  "$plot" "$work/a/mixed.json" "$work/b/results.json" --out "$work/chosen" --baseline-config cfg_a
expect "a config the file lacks" 1 "no successful runs of cfg_z in .*results.json" \
  "$plot" "$work/a/results.json" "$work/b/results.json" --out "$work/x" --candidate-config cfg_z
expect "an output directory that does not exist" 1 "directory .*/no_dir does not exist" \
  "$plot" "$work/a/results.json" "$work/b/results.json" --out "$work/no_dir/x"
expect "no successful runs" 1 "no successful runs in .*failed.json" \
  "$plot" "$work/a/failed.json" "$work/b/results.json" --out "$work/x"
expect "NaN, missing keys and a failed seed are plotted around" 0 "wrote .*gaps_seeds.png" \
  "$plot" "$work/a/gaps.json" "$work/b/results.json" --out "$work/gaps"
cp "$work/bags/w1_seed1.landmarks.yaml" "$work/w1_seed1.keep"
sed -i 's/points: \[\[-1, -2\]/points: [[-1]/' "$work/bags/w1_seed1.landmarks.yaml"
expect "a malformed object" 1 "cannot read the objects of .*w1_seed1.landmarks.yaml" \
  "$plot" "$work/a/results.json" "$work/b/results.json" --out "$work/x" \
  --map-world w1 --map-seed 1
cp "$work/w1_seed1.keep" "$work/bags/w1_seed1.landmarks.yaml"
rm "$work/b/runs/w1/2/trajectory.tum"
expect "a missing trajectory" 1 "cannot read trajectory .*w1/2/trajectory.tum" \
  "$plot" "$work/a/results.json" "$work/b/results.json" --out "$work/x" \
  --map-world w1 --map-seed 2
sed -i '5s/^\([^ ]*\) [^ ]*/\1 nan/' "$work/a/runs/w2/1/trajectory.tum"
expect "a NaN in a trajectory" 1 "w2/1/trajectory.tum is not a TUM trajectory with finite" \
  "$plot" "$work/a/results.json" "$work/b/results.json" --out "$work/x" \
  --map-world w2 --map-seed 1
exit $status
