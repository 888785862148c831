#!/usr/bin/env bash
# benchmarks/motion_coverage on a hand-made MRCLAM-format dataset: a robot driving an arc at
# constant v and w, sighted every second for 10 s and again after a 50 s silence. With the ground
# truth equal to the integrated commands every increment's Mahalanobis^2 is 0; with the true
# heading turned 0.6 rad during the silence (the model's heading sigma over that increment, 1 m
# and 0.5 rad, is about 0.15 rad) that increment lies beyond the 99 % bound. A missing file and a config with
# another motion model exit 1 naming them. The same moved 0.5 m instead lies beyond the bound too,
# and driving the arc backwards gives the forward heading sigma.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
source "$(dirname "$0")/lib/expect.sh"
coverage="$root/benchmarks/motion_coverage"
status=0

make_dataset() {  # DIR HEADING_STEP_RAD [X_STEP_M [V_M_PER_S]]
  mkdir -p "$1"
  /usr/bin/python3 - "$1" "$2" "${3:-0}" "${4:-0.02}" <<'PY'
import math, sys
out, step, shift, v = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
w, t0 = 0.01, 1000.0
with open(out + "/Barcodes.dat", "w") as f:
    f.write("# Subject # Barcode #\n1 5\n6 72\n")
with open(out + "/Robot1_Odometry.dat", "w") as f:
    f.write("# Time v w\n")
    for i in range(0, 181):
        f.write("%.3f %.3f %.3f\n" % (t0 + 0.5 * i, v, w))
with open(out + "/Robot1_Groundtruth.dat", "w") as f:
    f.write("# Time x y theta\n")
    for i in range(0, 181):
        t = 0.5 * i
        theta = w * t
        x, y = v / w * math.sin(theta), v / w * (1.0 - math.cos(theta))
        late = t >= 30.0  # the silence's ground truth moved by (shift, 0) and turned by step
        f.write("%.3f %.8f %.8f %.8f\n" % (t0 + t, x + (shift if late else 0.0), y,
                                           theta + (step if late else 0.0)))
with open(out + "/Robot1_Measurement.dat", "w") as f:
    f.write("# Time subject range bearing\n")
    for t in list(range(1, 11)) + [60, 61]:
        f.write("%.3f 72 3.0 0.1\n" % (t0 + t))
PY
}
make_dataset "$work/exact" 0
make_dataset "$work/turned" 0.6
make_dataset "$work/shifted" 0 0.5
make_dataset "$work/backwards" 0 0 -0.02

# The row of --list 40: the one increment across the silence ("SIGMA_DEG D2"; with a third
# argument "POS_ERR_M D2").
silence() {
  "$coverage" "$1" --robots 1 --list 40 |
    awk -v pos="${2:-}" '$1 == 1 && $3 == "50.0" {print (pos == "" ? $5 : $6), $NF}'
}
# Its heading sigma by hand: chord 2 v/w sin(0.25) = 0.990 m, rot1 = rot2 = 0.25 rad, so
# sqrt(2 (0.03 * 0.25^2 + 0.01 * 0.990^2) + 0.02^2) = 0.1541 rad = 8.8 deg.
check() {  # NAME "SIGMA_DEG D2" (or "POS_ERR_M D2") PYTHON_CONDITION_ON_s_AND_d
  if /usr/bin/python3 -c "import sys; s, d = map(float, '$2'.split()); sys.exit(0 if $3 else 1)"; then
    echo "ok: $1 (silence row: $2)"
  else
    echo "FAIL: $1: silence row '$2'"; status=1
  fi
}
check "exact ground truth: nothing across the silence" "$(silence "$work/exact")" \
  "s == 8.8 and d < 1e-6"
check "heading turned 0.6 rad in the silence: beyond 11.34" "$(silence "$work/turned")" \
  "s == 8.8 and d > 11.34"
# Moved 0.5 m along x instead: the model's position sigma across the silence is about 0.1 m
# along and across the chord, so the error (0.5 m in the frame of the pose before) is beyond.
check "moved 0.5 m in the silence: beyond 11.34" "$(silence "$work/shifted" pos)" \
  "s == 0.5 and d > 11.34"
# Driving backwards the chord points behind the robot: the model takes it as rot1 = 0.25 rad
# with a negative translation (not a half turn), so the heading sigma is the forward one.
check "backwards, exact ground truth: the forward sigma, nothing beyond" \
  "$(silence "$work/backwards")" "s == 8.8 and d < 1e-6"
expect "the summary counts the silence beyond the bound" 0 '^30-inf \| 1 \| [0-9.]+ \| 100\.0 %' \
  "$coverage" "$work/turned" --robots 1
expect "exact ground truth: the short increments at 0" 0 '^1-5 \| 10 \| 0\.00 \| 0\.0 %' \
  "$coverage" "$work/exact" --robots 1

rm "$work/exact/Robot1_Groundtruth.dat"
expect "missing ground truth" 1 'exact/Robot1_Groundtruth.dat: no such file' \
  "$coverage" "$work/exact" --robots 1
printf 'motion:\n  model: diff_drive\n' >"$work/diff.yaml"
expect "another motion model" 1 'diff.yaml: motion.model is diff_drive' \
  "$coverage" "$work/turned" --robots 1 --config "$work/diff.yaml"
printf 'motion:\n  alpha1: -1\n' >"$work/negative.yaml"
expect "a negative noise term" 1 'negative.yaml: motion.alpha1 = -1 is not a finite number >= 0' \
  "$coverage" "$work/turned" --robots 1 --config "$work/negative.yaml"
printf 'motion:\n  alpha1: 3e-2\n' >"$work/exponent.yaml"  # PyYAML reads 3e-2 as a string
expect "a noise term written 3e-2" 0 '^30-inf \| 1 \|' \
  "$coverage" "$work/turned" --robots 1 --config "$work/exponent.yaml"
printf '1000 0.02\n1001 0.02\n' >"$work/turned/Robot1_Odometry.dat"
expect "a table with a column missing" 1 'Robot1_Odometry.dat: 2 columns, expected 3 \(t v w\)' \
  "$coverage" "$work/turned" --robots 1
exit $status
