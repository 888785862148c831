#!/usr/bin/python3
"""The particle-count study of Yatim and Buniyamin (2015) for variant grid_pf.

For each world (e-puck with 8 IR sensors, Pioneer-like sonar ring) and seed: simulate a bag,
run offline_slam with 100, 300 and 500 particles, and compare x and y of the estimate with the
ground truth at every filter step; odometry alone is compared the same way. Errors are RMSE
over the seeds at each step (the paper's eq. 15 takes the RMSE over particles of one run; here
the estimate of each run is compared with the truth and the RMSE is over seeds). Estimates and
odometry are put in the world frame by their first pose (the map is anchored at the start).

  benchmarks/grid_pf_study.py [--seeds 10] [--jobs 2] [--work /tmp/grid_pf_study]
      [--worlds yatim_epuck,lee_sonar_room] [--particles 100,300,500] [--set key=value ...]

Writes docs/grid_pf_study.png, docs/grid_pf_study.json and prints a markdown table.
"""
import argparse
import bisect
import concurrent.futures
import json
import math
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import tum  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "devel", "lib", "rbpf_slam")
CONFIGS = {"yatim_epuck": "config/grid_pf.yaml", "lee_sonar_room": "config/grid_pf_sonar.yaml"}
REPORT_STEPS = [100, 200, 400, 600]


def read_tum(path):
    """[(t, x, y, yaw)] of a TUM file; exits naming the file and line when it cannot be read."""
    try:
        return tum.read_tum(path)
    except tum.TumError as error:
        sys.exit("grid_pf_study: %s" % error)


def read_odometry(bag_path):
    import rosbag  # ROS python, only needed here
    rows = []
    with rosbag.Bag(bag_path) as bag:
        for _, msg, _ in bag.read_messages(topics=["/tf", "tf"]):
            for t in msg.transforms:
                if t.header.frame_id.strip("/") == "odom" and t.child_frame_id.strip("/") == "base_link":
                    q = t.transform.rotation
                    rows.append((t.header.stamp.to_sec(), t.transform.translation.x,
                                 t.transform.translation.y, 2.0 * math.atan2(q.z, q.w)))
    rows.sort()
    return rows


def at(rows, t):
    """Pose of rows at time t (nearest neighbour; rows sorted by time)."""
    times = [r[0] for r in rows]
    i = bisect.bisect_left(times, t)
    if i == 0:
        return rows[0]
    if i >= len(rows):
        return rows[-1]
    return rows[i] if abs(rows[i][0] - t) < abs(rows[i - 1][0] - t) else rows[i - 1]


def align(rows, truth):
    """Moves rows so that its first pose coincides with the truth at that time."""
    t0, x0, y0, a0 = rows[0]
    _, tx, ty, ta = at(truth, t0)
    da = ta - a0
    c, s = math.cos(da), math.sin(da)
    out = []
    for t, x, y, a in rows:
        dx, dy = x - x0, y - y0
        out.append((t, tx + c * dx - s * dy, ty + s * dx + c * dy, a + da))
    return out


def errors(rows, truth, stamps):
    """(ex, ey) of rows against truth at the given stamps."""
    out = []
    for t in stamps:
        _, x, y, _ = at(rows, t)
        _, tx, ty, _ = at(truth, t)
        out.append((x - tx, y - ty))
    return out


def run(cmd):
    result = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if result.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), result.stderr[-2000:]))


def one_run(world, seed, particles, work, extra):
    bag = os.path.join(work, "%s_s%d.bag" % (world, seed))
    out = os.path.join(work, "%s_s%d_p%d" % (world, seed, particles))
    cmd = [os.path.join(BIN, "offline_slam"), "--bag", bag, "--config",
           os.path.join(ROOT, CONFIGS[world]), "--output", out, "--set", "particles=%d" % particles,
           "--set", "seed=%d" % seed]
    for e in extra:
        cmd += ["--set", e]
    run(cmd)
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return world, seed, particles, read_tum(os.path.join(out, "trajectory.tum")), summary


def simulate(world, seed, work):
    bag = os.path.join(work, "%s_s%d.bag" % (world, seed))
    if not os.path.exists(bag):
        run([os.path.join(BIN, "simulate"), "--world", os.path.join(ROOT, "worlds", world + ".yaml"),
             "--output", bag, "--seed", str(seed)])
    return world, seed, read_tum(bag[:-4] + ".ref.tum"), read_odometry(bag)


def rmse_series(per_seed):
    """per_seed: list of [(ex, ey)] per step -> ([rmse_x], [rmse_y]) over the common steps."""
    steps = min(len(e) for e in per_seed)
    rx = [math.sqrt(sum(e[k][0] ** 2 for e in per_seed) / len(per_seed)) for k in range(steps)]
    ry = [math.sqrt(sum(e[k][1] ** 2 for e in per_seed) / len(per_seed)) for k in range(steps)]
    return rx, ry


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--work", default="/tmp/grid_pf_study")
    parser.add_argument("--worlds", default="yatim_epuck,lee_sonar_room")
    parser.add_argument("--particles", default="100,300,500")
    parser.add_argument("--set", action="append", default=[])
    parser.add_argument("--output", default=os.path.join(ROOT, "docs", "grid_pf_study"))
    parser.add_argument("--from-json", help="re-plot and re-print a previous run's JSON")
    args = parser.parse_args()
    if args.from_json:
        report(load_results(args.from_json), args.output)
        return
    os.makedirs(args.work, exist_ok=True)
    worlds = args.worlds.split(",")
    counts = [int(p) for p in args.particles.split(",")]
    seeds = list(range(1, args.seeds + 1))
    truth, odometry, estimates, summaries = {}, {}, {}, {}
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        for world, seed, ref, odom in pool.map(lambda ws: simulate(ws[0], ws[1], args.work),
                                              [(w, s) for w in worlds for s in seeds]):
            truth[world, seed], odometry[world, seed] = ref, odom
        jobs = [(w, s, p) for w in worlds for p in counts for s in seeds]
        for world, seed, p, traj, summary in pool.map(
                lambda j: one_run(j[0], j[1], j[2], args.work, args.set), jobs):
            estimates[world, seed, p] = traj
            summaries[world, seed, p] = summary
    results = {}
    for world in worlds:
        series = {}
        for p in counts:
            series[str(p)] = rmse_series([
                errors(align(estimates[world, s, p], truth[world, s]), truth[world, s],
                       [r[0] for r in estimates[world, s, p]]) for s in seeds])
        # Odometry at the stamps of the first particle count's steps.
        series["odometry"] = rmse_series([
            errors(align(odometry[world, s], truth[world, s]), truth[world, s],
                   [r[0] for r in estimates[world, s, counts[0]]]) for s in seeds])
        wall = {str(p): sum(summaries[world, s, p]["wall_s"] for s in seeds) / len(seeds)
                for p in counts}
        rss = {str(p): max(summaries[world, s, p].get("peak_rss_mb", 0) for s in seeds)
               for p in counts}
        results[world] = {"series": series, "wall_s_mean": wall, "peak_rss_mb_max": rss,
                          "seeds": len(seeds)}
    for world in results:  # 0.1 mm is plenty
        results[world]["series"] = {n: [[round(v, 5) for v in axis] for axis in xy]
                                    for n, xy in results[world]["series"].items()}
    with open(args.output + ".json", "w") as f:
        json.dump(results, f)
    report(results, args.output)


def load_results(path):
    """A previous run's JSON, checked for the keys report() reads; exits naming what is wrong."""
    try:
        with open(path) as f:
            results = json.load(f)
    except OSError as error:
        sys.exit("grid_pf_study: cannot read %s: %s" % (path, error.strerror or error))
    except ValueError as error:  # JSONDecodeError and UnicodeDecodeError
        sys.exit("grid_pf_study: %s is not JSON: %s" % (path, error))
    if not isinstance(results, dict) or not results:
        sys.exit("grid_pf_study: %s holds no worlds (expected {world: {...}})" % path)
    for world, entry in results.items():
        where = "%s: world '%s'" % (path, world)
        if not isinstance(entry, dict):
            sys.exit("grid_pf_study: %s is not a mapping" % where)
        for key in ("series", "seeds", "wall_s_mean", "peak_rss_mb_max"):
            if key not in entry:
                sys.exit("grid_pf_study: %s lacks '%s'" % (where, key))
        if not isinstance(entry["seeds"], int) or isinstance(entry["seeds"], bool):
            sys.exit("grid_pf_study: %s: 'seeds' is not a whole number" % where)
        series = entry["series"]
        if not isinstance(series, dict) or "odometry" not in series:
            sys.exit("grid_pf_study: %s: 'series' needs an 'odometry' entry" % where)
        for name, xy in series.items():
            if (not isinstance(xy, list) or len(xy) != 2 or
                    not all(isinstance(axis, list) and axis and
                            all(isinstance(v, (int, float)) for v in axis) for axis in xy)):
                sys.exit("grid_pf_study: %s: series '%s' is not two non-empty lists of numbers"
                         % (where, name))
    names = list(next(iter(results.values()))["series"])
    for world, entry in results.items():
        if list(entry["series"]) != names:
            sys.exit("grid_pf_study: %s: world '%s' has series %s, the first world %s"
                     % (path, world, list(entry["series"]), names))
    return results


def report(results, output):
    worlds = list(results)
    names = list(results[worlds[0]]["series"])
    counts = [n for n in names if n != "odometry"]
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2, len(worlds), figsize=(6 * len(worlds), 7), squeeze=False)
    colours = {"100": "tab:red", "300": "tab:green", "500": "tab:blue", "odometry": "grey"}
    for col, world in enumerate(worlds):
        for row, axis in enumerate("xy"):
            ax = axes[row][col]
            for name, (rx, ry) in results[world]["series"].items():
                label = name if name == "odometry" else name + " particles"
                ax.plot(rx if row == 0 else ry, label=label, color=colours.get(name),
                        linestyle="--" if name == "odometry" else "-")
            ax.set_title("%s: RMSE of %s (%d seeds)" % (world, axis, results[world]["seeds"]))
            ax.set_xlabel("filter step")
            ax.set_ylabel("RMSE %s [m]" % axis)
            ax.grid(alpha=0.3)
            ax.legend()
    fig.tight_layout()
    fig.savefig(output + ".png", dpi=90)
    # Tables.
    for world in worlds:
        series = results[world]["series"]
        print("\n%s (%d seeds): RMSE x / y [m] at filter step" % (world, results[world]["seeds"]))
        n_last = min(len(series[n][0]) for n in names)
        print("| | " + " | ".join("step %d" % k for k in REPORT_STEPS) +
              " | step %d (last) | mean over steps >= 600 | steps >= 600 below odometry (x / y) |" % n_last)
        print("|---" * (len(REPORT_STEPS) + 4) + "|")
        ox, oy = series["odometry"]
        for name in counts + ["odometry"]:
            rx, ry = series[name]
            cells = []
            for k in REPORT_STEPS + [n_last]:
                k = min(k, len(rx)) - 1
                cells.append("%.4f / %.4f" % (rx[k], ry[k]))
            late = range(600, min(len(rx), len(ox)))
            if not late:  # runs of fewer than 601 steps
                cells.append("n/a")
                below = "n/a" if name != "odometry" else ""
            else:
                cells.append("%.4f / %.4f" % (sum(rx[k] for k in late) / len(late),
                                              sum(ry[k] for k in late) / len(late)))
                below = ("%.0f%% / %.0f%%" % (100.0 * sum(rx[k] < ox[k] for k in late) / len(late),
                                              100.0 * sum(ry[k] < oy[k] for k in late) / len(late))
                         if name != "odometry" else "")
            cells.append(below)
            label = name if name == "odometry" else name + " particles"
            print("| %s | %s |" % (label, " | ".join(cells)))
        print("wall s per run (mean): %s; peak RSS MB (max): %s" % (
            results[world]["wall_s_mean"], results[world]["peak_rss_mb_max"]))

if __name__ == "__main__":
    main()
