#!/usr/bin/python3
"""How often a UTIAS MRCLAM robot's camera reports a landmark that is in its view.

usage: mrclam_detection_rates.py [DATASET_DIR] [--robots 1,2,3,4,5] [--half-fov RAD]

For every camera frame of each robot (a stamp of RobotN_Measurement.dat; the file holds only
frames that report at least one barcode, so the rates are conditional on that) and every surveyed
landmark (Landmark_Groundtruth.dat), the robot's pose is interpolated from RobotN_Groundtruth.dat
(Vicon) and the landmark's range and bearing computed. Prints, per range band, the fraction of
frames with the landmark within +-half-fov of the heading in which its barcode was reported (the
detection probability that negative evidence, existence.visible_range_m, relies on), and per
bearing band (ranges 0.5-5 m) the same fraction. Barcodes map to subjects by Barcodes.dat;
subjects 1-5 are the robots and are not landmarks.

Used for docs/results.md, "Session 21" (dataset 6):
  tools/mrclam_detection_rates.py ../shared/data/mrclam6
"""

import argparse
import collections
import sys
from pathlib import Path

import numpy as np

RANGE_BANDS = [0.5, 1.5, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 6.0, 7.0]
BEARING_STEP = 0.1


def load(path):
    if not path.is_file():
        sys.exit("mrclam_detection_rates: missing %s" % path)
    return np.loadtxt(path, comments="#", ndmin=2)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    default = Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "mrclam6"
    parser.add_argument("data", nargs="?", default=str(default))
    parser.add_argument("--robots", default="1,2,3,4,5")
    parser.add_argument("--half-fov", type=float, default=0.3,
                        help="half width of the view for the range table, rad (default 0.3)")
    a = parser.parse_args(argv)
    data = Path(a.data)
    subject_of = {int(b): int(s) for s, b in load(data / "Barcodes.dat")}
    landmarks = {int(r[0]): r[1:3] for r in load(data / "Landmark_Groundtruth.dat")}
    in_view, seen = collections.Counter(), collections.Counter()
    b_in_view, b_seen = collections.Counter(), collections.Counter()
    for robot in [int(r) for r in a.robots.split(",") if r]:
        truth = load(data / ("Robot%d_Groundtruth.dat" % robot))
        heading = np.unwrap(truth[:, 3])
        frames = collections.defaultdict(set)
        for stamp, barcode, _, _ in load(data / ("Robot%d_Measurement.dat" % robot)):
            frames[round(stamp, 2)].add(subject_of.get(int(barcode), -1))
        for stamp, subjects in frames.items():
            if stamp < truth[0, 0] or stamp > truth[-1, 0]:
                continue
            x = np.interp(stamp, truth[:, 0], truth[:, 1])
            y = np.interp(stamp, truth[:, 0], truth[:, 2])
            theta = np.interp(stamp, truth[:, 0], heading)
            for subject, position in landmarks.items():
                dx, dy = position[0] - x, position[1] - y
                r = float(np.hypot(dx, dy))
                b = float((np.arctan2(dy, dx) - theta + np.pi) % (2 * np.pi) - np.pi)
                band = int(np.searchsorted(RANGE_BANDS, r))
                if abs(b) <= a.half_fov and 0 < band < len(RANGE_BANDS):
                    in_view[band] += 1
                    seen[band] += subject in subjects
                if 0.5 < r < 5.0:
                    k = int(abs(b) / BEARING_STEP)
                    b_in_view[k] += 1
                    b_seen[k] += subject in subjects
    print("| range [m] | frames in view (+-%.2f rad) | reported |" % a.half_fov)
    print("|---|---|---|")
    for band in sorted(in_view):
        print("| %.1f-%.1f | %d | %.2f |" % (RANGE_BANDS[band - 1], RANGE_BANDS[band],
                                           in_view[band], seen[band] / in_view[band]))
    print("\n| abs bearing [rad] (0.5-5 m) | frames | reported |")
    print("|---|---|---|")
    for k in sorted(b_in_view):
        if k * BEARING_STEP > 1.0:
            break
        print("| %.1f-%.1f | %d | %.2f |" % (k * BEARING_STEP, (k + 1) * BEARING_STEP,
                                           b_in_view[k], b_seen[k] / b_in_view[k]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
