#!/usr/bin/python3
"""Where the MRCLAM landmark maps' errors come from: the data, the path, or the landmark filter.

usage: mrclam_map_error.py vicon [DATASET_DIR] [--robots 1,2,3,4,5]
       mrclam_map_error.py runs OUT [--config landmarks_hinf] [--data DATASET_DIR]

vicon: for each robot and surveyed landmark (Landmark_Groundtruth.dat), the landmark is mapped
from the Vicon poses (RobotN_Groundtruth.dat, interpolated at the camera's stamps) and the
camera's range and bearing (RobotN_Measurement.dat), by Gauss-Newton with mrclam_to_bag's feature
noise (range 0.03 m + 0.035 x range, bearing 0.02 rad; residuals beyond 3 sigma dropped). Prints
per robot the largest and mean distance to the surveyed positions and the mean radial offset
(outwards from the surveyed landmarks' centroid; negative: the map is drawn in). What a perfect
path would give: the floor of issue 6's "within 0.3 m".

runs: for an OUT directory of benchmarks/run_mrclam (results.json, bags/, runs/CONFIG/), per
robot, medians over the seeds of:
  - the mapped point landmarks' radial offset and |tangential| offset, after the runner's
    alignment (trajectory, then a rigid fit of all point landmarks to the nearest surveyed
    ones); landmarks seen at least 30 times, matched within 0.5 m;
  - the best particle's pose error at the update stamps in the true robot frame (along the
    heading, lateral) and its heading error (RMS), after the trajectory's alignment;
  - with runs made with --known-ids (the landmark of every sighting known): each landmark
    mapped again from the filter's own best path (trajectory alignment) and the measurements
    (Gauss-Newton as `vicon`), against the filter's own landmark: where the two agree, the map's
    error is the path's error, not the landmark filter's.

Used for docs/results.md, "Session 23" (dataset 6):
  tools/mrclam_map_error.py vicon ../shared/data/mrclam6
  benchmarks/run_mrclam --configs landmarks_hinf --seeds 37,...,45 --known-ids --out OUT
  tools/mrclam_map_error.py runs OUT --config landmarks_hinf
"""

import argparse
import importlib.machinery
import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_DATA = ROOT.parent / "shared" / "data" / "mrclam6"
MIN_SEEN = 30  # landmarks seen fewer times are left out of the offsets (young, uncertain)


def run_mrclam():
    """benchmarks/run_mrclam as a module: its alignment and evaluation, not a copy of them."""
    loader = importlib.machinery.SourceFileLoader("run_mrclam", str(ROOT / "benchmarks" / "run_mrclam"))
    spec = importlib.util.spec_from_loader("run_mrclam", loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def load(path):
    if not Path(path).is_file():
        sys.exit("mrclam_map_error: missing %s" % path)
    return np.loadtxt(path, comments="#", ndmin=2)


def dataset(data):
    data = Path(data)
    barcodes = {int(b): int(s) for s, b in load(data / "Barcodes.dat")}
    surveyed = {int(r[0]): r[1:3] for r in load(data / "Landmark_Groundtruth.dat")}
    return barcodes, surveyed


def measurements_of(data, robot, barcodes, subject, t_min, t_max):
    m = load(Path(data) / ("Robot%d_Measurement.dat" % robot))
    m = m[(m[:, 0] >= t_min) & (m[:, 0] <= t_max)]
    return m[np.array([barcodes.get(int(b)) == subject for b in m[:, 1]], dtype=bool)]


def radial_offset(point, subject_xy, centre):
    u = (subject_xy - centre) / np.linalg.norm(subject_xy - centre)
    off = point - subject_xy
    return float(off @ u), float(abs(off @ np.array([-u[1], u[0]])))


def map_from_poses(x, y, heading, r, b):
    """Gauss-Newton landmark from poses and range-bearing sightings (mrclam_to_bag's noise)."""
    sr, sb = 0.03 + 0.035 * r, 0.02
    lm = np.array([np.median(x + r * np.cos(heading + b)), np.median(y + r * np.sin(heading + b))])
    for _ in range(10):
        dx, dy = lm[0] - x, lm[1] - y
        q = dx * dx + dy * dy
        pr = np.sqrt(q)
        er = r - pr
        eb = np.angle(np.exp(1j * (b - (np.arctan2(dy, dx) - heading))))
        keep = (np.abs(er) < 3 * sr) & (np.abs(eb) < 3 * sb)
        if keep.sum() < 3:
            break
        hr = np.stack([dx / pr, dy / pr], 1)[keep]
        hb = np.stack([-dy / q, dx / q], 1)[keep]
        w = 1.0 / sr[keep] ** 2
        a = (hr.T * w) @ hr + hb.T @ hb / sb ** 2
        g = (hr.T * w) @ er[keep] + hb.T @ eb[keep] / sb ** 2
        lm = lm + np.linalg.solve(a, g)
    return lm


def vicon(args):
    barcodes, surveyed = dataset(args.data)
    centre = np.mean(list(surveyed.values()), 0)
    print("| robot | landmarks | max err [m] | mean err [m] | mean radial offset [m] |")
    print("|---|---|---|---|---|")
    for robot in [int(r) for r in args.robots.split(",") if r]:
        gt = load(Path(args.data) / ("Robot%d_Groundtruth.dat" % robot))
        heading = np.unwrap(gt[:, 3])
        errors, radial = [], []
        for subject in sorted(surveyed):
            m = measurements_of(args.data, robot, barcodes, subject, gt[0, 0], gt[-1, 0])
            if len(m) < 10:
                continue
            t = m[:, 0]
            lm = map_from_poses(np.interp(t, gt[:, 0], gt[:, 1]), np.interp(t, gt[:, 0], gt[:, 2]),
                                np.interp(t, gt[:, 0], heading), m[:, 2], m[:, 3])
            errors.append(np.linalg.norm(lm - surveyed[subject]))
            radial.append(radial_offset(lm, surveyed[subject], centre)[0])
        if not errors:
            print("| %d | 0 | n/a | n/a | n/a |" % robot)
            continue
        print("| %d | %d | %.3f | %.3f | %+.3f |" % (robot, len(errors), max(errors),
                                                    np.mean(errors), np.mean(radial)))


def yaw(tum):
    return np.arctan2(2 * tum[:, 7] * tum[:, 6], 1 - 2 * tum[:, 6] ** 2)


def one_run(rm, out, config, record, barcodes, surveyed, data):
    import yaml  # only here: `vicon` needs no PyYAML
    suffix = ("_known" if record.get("known_ids") else "") + (
        "_delay%g" % record["command_delay_s"] if record.get("command_delay_s") else "")
    prefix = out / "bags" / ("robot%d%s" % (record["robot"], suffix))
    run = out / "runs" / config / ("robot%d_seed%d%s" % (record["robot"], record["seed"], suffix))
    ref = load(str(prefix) + ".ref.tum")
    odom = load(str(prefix) + ".odom.tum")
    est = load(run / "trajectory.tum")
    # The runner's window: stamps covered by both the reference and the odometry.
    est = est[(est[:, 0] >= max(ref[0, 0], odom[0, 0])) & (est[:, 0] <= min(ref[-1, 0], odom[-1, 0]))]
    truth = rm.interpolate(est[:, 0], ref[:, 0], ref[:, 1:3])
    _, rot, shift = rm.ate(est[:, 1:3], truth)
    angle = math.atan2(rot[1, 0], rot[0, 0])
    path = est[:, 1:3] @ rot.T + shift
    path_heading = np.unwrap(yaw(est) + angle)
    true_heading = np.interp(est[:, 0], ref[:, 0], np.unwrap(yaw(ref)))
    e = path - truth
    along = e[:, 0] * np.cos(true_heading) + e[:, 1] * np.sin(true_heading)
    lateral = -e[:, 0] * np.sin(true_heading) + e[:, 1] * np.cos(true_heading)
    heading_error = np.angle(np.exp(1j * (path_heading - true_heading)))

    # The mapped landmarks, aligned as the runner does (trajectory, then a rigid fit of all point
    # landmarks to their nearest surveyed ones); offsets of those seen >= MIN_SEEN times.
    listed = yaml.safe_load(open(str(prefix) + ".landmarks.yaml"))["landmarks"]
    sv = np.array([[l["x_m"], l["y_m"]] for l in listed])
    centre = sv.mean(0)
    points = [p for p in (yaml.safe_load(open(run / "landmarks.yaml")).get("landmarks") or [])
              if p["type"] == "point"]
    offsets = []
    if points:
        xy = np.array([[p["x"], p["y"]] for p in points])
        aligned = rm.align_landmarks(xy, rot, shift, sv, 0.5)
        d = np.linalg.norm(aligned[:, None] - sv[None], axis=2)
        for i in np.where(d.min(1) < 0.5)[0]:
            if points[i]["observations"] >= MIN_SEEN:
                offsets.append(radial_offset(aligned[i], sv[d[i].argmin()], centre))

    # Known ids: each landmark mapped again from the filter's own path (trajectory alignment only).
    remapped = []
    if record.get("known_ids"):
        for p in (yaml.safe_load(open(run / "landmarks.yaml")).get("landmarks") or []):
            if p["type"] != "point" or p["id"] not in surveyed:
                continue
            m = measurements_of(data, record["robot"], barcodes, p["id"], est[0, 0], est[-1, 0])
            if len(m) < 10:
                continue
            t = m[:, 0]
            proj = map_from_poses(np.interp(t, est[:, 0], path[:, 0]),
                                  np.interp(t, est[:, 0], path[:, 1]),
                                  np.interp(t, est[:, 0], path_heading), m[:, 2], m[:, 3])
            own = np.array([p["x"], p["y"]]) @ rot.T + shift
            remapped.append((np.linalg.norm(proj - surveyed[p["id"]]),
                             np.linalg.norm(own - surveyed[p["id"]]), np.linalg.norm(proj - own)))
    return {
        "radial": np.mean([o[0] for o in offsets]) if offsets else np.nan,
        "tangential": np.mean([o[1] for o in offsets]) if offsets else np.nan,
        "along": float(np.mean(along)), "lateral": float(np.mean(lateral)),
        "heading_rms_deg": math.degrees(float(np.sqrt(np.mean(heading_error ** 2)))),
        "remapped_max": max(r[0] for r in remapped) if remapped else np.nan,
        "own_max": max(r[1] for r in remapped) if remapped else np.nan,
        "remapped_vs_own": float(np.mean([r[2] for r in remapped])) if remapped else np.nan,
    }


def runs(args):
    out = Path(args.out)
    results = out / "results.json"
    if not results.is_file():
        sys.exit("mrclam_map_error: missing %s (an OUT of benchmarks/run_mrclam)" % results)
    rm = run_mrclam()
    stored = json.load(open(results))
    data = args.data
    if data is None:  # the dataset the runs were made from (run_mrclam --data), else the default
        words = stored.get("command", "").split()
        data = words[words.index("--data") + 1] if "--data" in words[:-1] else str(DEFAULT_DATA)
    barcodes, surveyed = dataset(data)
    per = {}
    for record in stored["runs"]:
        if record["config"] != args.config:
            continue
        per.setdefault(record["robot"], []).append(
            one_run(rm, out, args.config, record, barcodes, surveyed, data))
    if not per:
        sys.exit("mrclam_map_error: no run of config %s in %s" % (args.config, results))
    keys = ["radial", "tangential", "along", "lateral", "heading_rms_deg", "remapped_max",
            "own_max", "remapped_vs_own"]
    print("| robot | runs | landmark radial offset [m] | abs tangential [m] | pose error along the "
          "heading [m] | lateral [m] | heading error RMS [deg] | known ids, trajectory alignment "
          "only: max err of the landmarks re-mapped from the filter's path [m] | the filter's "
          "own max err [m] | mean distance between the two [m] |")
    print("|---" * (len(keys) + 2) + "|")
    for robot in sorted(per):
        med = [np.nanmedian([r[k] for r in per[robot]]) if any(np.isfinite(r[k]) for r in per[robot])
               else np.nan for k in keys]
        formats = ["%+.3f", "%.3f", "%+.3f", "%+.3f", "%.1f", "%.2f", "%.2f", "%.2f"]
        cells = ["n/a" if not np.isfinite(v) else f % v for f, v in zip(formats, med)]
        print("| %d | %d | %s |" % (robot, len(per[robot]), " | ".join(cells)))


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="\n\n".join(__doc__.split("\n\n")[1:]))
    sub = parser.add_subparsers(dest="command", required=True)
    v = sub.add_parser("vicon", help="landmarks mapped from the Vicon poses")
    v.add_argument("data", nargs="?", default=str(DEFAULT_DATA))
    v.add_argument("--robots", default="1,2,3,4,5")
    r = sub.add_parser("runs", help="offsets of a run_mrclam output")
    r.add_argument("out")
    r.add_argument("--config", default="landmarks_hinf")
    r.add_argument("--data", default=None,
                   help="dataset the runs were made from (default: run_mrclam's --data, read "
                        "from OUT/results.json, else ../shared/data/mrclam6)")
    args = parser.parse_args(argv)
    if args.command == "vicon":
        vicon(args)
    else:
        runs(args)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
