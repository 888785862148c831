#!/usr/bin/env bash
# Every tool's command line (one parser, io/tool_arguments.h): -h / --help prints the usage and
# exits 0, a bad argument exits 2 (usage), an input that cannot be read exits 1 with a message
# naming it (validate_bag: 2, its 1 means problems found); no converter leaves a bag behind on
# failure.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
source "$(dirname "$0")/lib/expect.sh"
status=0

missing="$work/no_such_input"
expect "carmen_to_bag --help" 0 "usage: carmen_to_bag" "$bin/carmen_to_bag" --help
expect "carmen_to_bag bad option" 2 "usage: carmen_to_bag" "$bin/carmen_to_bag" a b --bogus
expect "carmen_to_bag missing log" 1 "no_such_input" "$bin/carmen_to_bag" "$missing.log" "$work/c.bag"
# Every scan malformed (a NaN beam): the reason, not only "no FLASER scan".
printf 'FLASER 3 nan 1 1 0 0 0 0 0 0 0 0 0 localhost 0\nFLASER 3 1 nan 1 0 0 0 0 0 0 0 0 1 localhost 1\n' \
  >"$work/nan.log"
expect "carmen_to_bag absurd bias" 2 "--odom-bias 1e\\+307 is outside" \
  "$bin/carmen_to_bag" "$work/nan.log" "$work/c.bag" --odom-bias 1e307
expect "carmen_to_bag only malformed scans" 1 "no FLASER scan in the log that could be used \\(2 malformed" \
  "$bin/carmen_to_bag" "$work/nan.log" "$work/c.bag"
expect "mrclam_to_bag --help" 0 "usage: mrclam_to_bag" "$bin/mrclam_to_bag" -h
expect "mrclam_to_bag bad robot" 2 "usage: mrclam_to_bag" "$bin/mrclam_to_bag" "$work" x "$work/m.bag"
expect "mrclam_to_bag negative delay" 2 "--command-delay needs a non-negative number, got '-1'" \
  "$bin/mrclam_to_bag" "$work" 1 "$work/m.bag" --command-delay -1
expect "mrclam_to_bag absurd sigma" 2 "--sigma-bearing-rad 1e\\+300 is above 3.14159" \
  "$bin/mrclam_to_bag" "$work" 1 "$work/m.bag" --sigma-bearing-rad 1e300
expect "mrclam_to_bag negative start" 2 "--start needs a non-negative number, got '-5'" \
  "$bin/mrclam_to_bag" "$work" 1 "$work/m.bag" --start -5
expect "mrclam_to_bag missing dataset" 1 "no_such_input" "$bin/mrclam_to_bag" "$missing" 1 "$work/m.bag"
expect "victoria_park_to_bag --help" 0 "usage: victoria_park_to_bag" "$bin/victoria_park_to_bag" --help
expect "victoria_park_to_bag bad option" 2 "usage: victoria_park_to_bag" \
  "$bin/victoria_park_to_bag" a b --dt
expect "victoria_park_to_bag missing input" 1 "no_such_input" \
  "$bin/victoria_park_to_bag" "$missing.txt" "$work/v.bag"
for tool in offline_slam simulate evaluate render_grid validate_bag; do
  expect "$tool --help" 0 "usage: $tool" "$bin/$tool" --help
done
expect "offline_slam unknown option" 2 "unknown argument '--bogus'" \
  "$bin/offline_slam" --bogus
expect "offline_slam value missing" 2 "--bag needs a value" "$bin/offline_slam" --bag
expect "offline_slam missing bag" 1 "no_such_input" "$bin/offline_slam" --bag "$missing.bag" \
  --config "$root/config/landmarks_fastslam2.yaml" --output "$work/o"
expect "offline_slam bad seed" 2 "--seed needs a non-negative integer" "$bin/offline_slam" \
  --bag x.bag --config x.yaml --output "$work/o" --seed x
for pose in 1,2 1,2,3, 1,2,nan 1,2,3,0,1; do
  expect "offline_slam bad start pose $pose" 2 "--initial-pose" "$bin/offline_slam" --bag x.bag \
    --config x.yaml --output x --initial-pose "$pose"
done
expect "offline_slam bad override" 2 "--set needs key=value" "$bin/offline_slam" --bag x.bag \
  --config x.yaml --output "$work/o" --set particles
expect "offline_slam bad config value" 1 "particles" "$bin/offline_slam" --bag "$missing.bag" \
  --config "$root/config/landmarks_fastslam2.yaml" --output "$work/o" --set particles=-3
expect "simulate bad seed" 2 "--seed needs a non-negative integer" "$bin/simulate" \
  --world "$root/worlds/test_small.yaml" --output "$work/s.bag" --seed -1
expect "simulate missing world" 1 "no_such_input" "$bin/simulate" --world "$missing.yaml" \
  --output "$work/s.bag"
expect "offline_slam nested output" 0 "updates" "$bin/offline_slam" --bag \
  "$root/test/data/intel_head.bag" --config "$root/config/laser_fastslam2.yaml" \
  --output "$work/new/nested/run" --no-progress --set particles=5
[ -s "$work/new/nested/run/trajectory.tum" ] || { echo "FAIL: no nested trajectory"; status=1; }
touch "$work/a_file"
expect "offline_slam output is a file" 1 "a_file: cannot create the output directory" \
  "$bin/offline_slam" --bag "$root/test/data/intel_head.bag" \
  --config "$root/config/laser_fastslam2.yaml" --output "$work/a_file" --no-progress
# Mistakes that used to give exit 0 with nothing mapped, or a wrong diagnosis (session 13):
head_bag="$root/test/data/intel_head.bag"
laser_config="$root/config/laser_fastslam2.yaml"
expect "offline_slam wrong base frame" 1 \
  "without tf; the first: odom -> base_footprint .*does not exist" \
  "$bin/offline_slam" --bag "$head_bag" --config "$laser_config" --output "$work/tf" \
  --no-progress --set base_frame=base_footprint
expect "offline_slam reference not evaluated" 1 "--reference .*was not evaluated" \
  "$bin/offline_slam" --bag "$head_bag" --config "$laser_config" --output "$work/ref" \
  --no-progress --set particles=5 --reference "$work/a_file"
expect "offline_slam topic of the wrong type" 1 \
  "topic '/odom' carries nav_msgs/Odometry, but scan_topic needs sensor_msgs/LaserScan" \
  "$bin/offline_slam" --bag "$head_bag" --config "$laser_config" --output "$work/type" \
  --no-progress --set scan_topic=/odom
expect "offline_slam grid_pf without raw readings" 1 \
  "no messages on 'ir' \(grid_pf maps raw sonar readings, not features\); the bag has .*'/scan'" \
  "$bin/offline_slam" --bag "$head_bag" --config "$root/config/grid_pf.yaml" \
  --output "$work/grid" --no-progress
# A damaged bag: one /scan message cut short. offline_slam maps the rest and names it;
# validate_bag reports it (both stopped at it before, with no topic named).
/usr/bin/python3 - "$head_bag" "$work/cut.bag" <<'PY'
import sys
import rosbag
cut = False
with rosbag.Bag(sys.argv[1]) as bag, rosbag.Bag(sys.argv[2], "w") as out:
    for topic, raw, t in bag.read_messages(raw=True):
        if topic == "/scan" and not cut and t.to_sec() > bag.get_start_time() + 100:
            datatype, data, md5sum, position, pytype = raw
            raw = (datatype, data[: len(data) // 2], md5sum, position, pytype)
            cut = True
        out.write(topic, raw, t, raw=True)
PY
expect "offline_slam a message cut short" 0 \
  "malformed message\(s\); the first: /scan: a message that does not decode" \
  "$bin/offline_slam" --bag "$work/cut.bag" --config "$laser_config" --output "$work/cut" \
  --no-progress --set particles=5
expect "validate_bag a message cut short" 1 "/scan: 1 message\(s\) that do not decode" \
  "$bin/validate_bag" "$work/cut.bag"
cp "$head_bag" "$work/same.bag"
size_before=$(stat -c %s "$work/same.bag")
expect "offline_slam output bag = input bag" 1 "is the input bag .*would destroy the recording" \
  "$bin/offline_slam" --bag "$work/same.bag" --config "$laser_config" --output "$work/same" \
  --no-progress --output-bag "$work/./same.bag"
[ "$(stat -c %s "$work/same.bag")" -eq "$size_before" ] ||
  { echo "FAIL: the input bag was overwritten"; status=1; }
printf '1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n' >"$work/a.tum"
expect "evaluate bad number" 2 "--max-dt needs a non-negative number" "$bin/evaluate" \
  "$work/a.tum" "$work/a.tum" --max-dt x
expect "evaluate one file" 2 "expected ESTIMATE.tum and REFERENCE.tum" "$bin/evaluate" "$work/a.tum"
expect "evaluate missing file" 1 "no_such_input" "$bin/evaluate" "$work/a.tum" "$missing.tum"
expect "evaluate itself" 0 "ate" "$bin/evaluate" "$work/a.tum" "$work/a.tum"
for t in 1 2 3 4 5 6; do echo "$t $((t - 1)) 0 0 0 0 0 1"; done >"$work/six.tum"
printf '1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n20 2 0 0 0 0 0 1\n30 3 0 0 0 0 0 1\n40 4 0 0 0 0 0 1\n' \
  >"$work/far.tum"
expect "evaluate few matches" 0 "only 2 of 6 estimate poses matched" "$bin/evaluate" \
  "$work/six.tum" "$work/far.tum"
# One matched pose aligns onto itself (an ATE of 0 whatever the error): refused unless --no-align.
printf '1 5 0 0 0 0 0 1\n' >"$work/one.tum"
expect "evaluate one matched pose" 1 "only 1 matched pose\(s\): the alignment needs at least 2" \
  "$bin/evaluate" "$work/one.tum" "$work/far.tum"
expect "evaluate one matched pose, --no-align" 0 '"ate_rmse_m": 5' \
  "$bin/evaluate" "$work/one.tum" "$work/far.tum" --no-align
cat "$work/six.tum" "$work/six.tum" >"$work/twice.tum"
# A diverged estimate (1e300 m) is read, but its errors overflow: no null figures with exit 0.
for t in 1 2 3 4 5 6; do echo "$t 1e300 1e300 0 0 0 0 1"; done >"$work/diverged.tum"
expect "evaluate a device" 1 "/dev/zero: is a device, not a file" "$bin/evaluate" /dev/zero \
  "$work/six.tum"
expect "simulate a device" 1 "/dev/zero: is a device, not a world file" "$bin/simulate" \
  --world /dev/zero --output "$work/z.bag"
expect "evaluate overflowing errors" 1 "the errors overflow" "$bin/evaluate" \
  "$work/diverged.tum" "$work/six.tum" --no-align
expect "evaluate stamps out of order" 0 \
  "twice.tum: 1 pose\(s\) stamped at or before the pose above them \(the first is pose 7\)" \
  "$bin/evaluate" "$work/twice.tum" "$work/six.tum"
expect "evaluate --max-gap without --interpolate" 2 "--max-gap applies only with --interpolate" \
  "$bin/evaluate" "$work/a.tum" "$work/a.tum" --max-gap 1
expect "render_grid required" 2 "are required" "$bin/render_grid" --bag x.bag
expect "render_grid missing reference" 1 "no_such_input" "$bin/render_grid" --bag "$missing.bag" \
  --reference "$missing.tum" --config "$root/config/grid_pf_laser.yaml" --output "$work/g"
# A bag file cut short (a copy interrupted mid-way): every reader names the file.
head -c 800000 "$root/test/data/intel_head.bag" >"$work/truncated.bag"
expect "render_grid truncated bag" 1 "truncated.bag: cannot open bag" "$bin/render_grid" \
  --bag "$work/truncated.bag" --reference "$root/test/data/intel_head.ref.tum" \
  --config "$root/config/grid_pf_laser.yaml" --output "$work/g"
expect "offline_slam truncated bag" 1 "truncated.bag: cannot open bag" "$bin/offline_slam" \
  --bag "$work/truncated.bag" --config "$root/config/laser_fastslam2.yaml" --output "$work/t"
expect "validate_bag truncated bag" 2 "truncated.bag: cannot open bag" "$bin/validate_bag" \
  "$work/truncated.bag"
# A write that fails half-way (here a file size limit; on a robot, a full disk): the tool says
# which bag, exits 1, and leaves neither a truncated bag nor its .part file (before: rosbag threw
# from a destructor, std::terminate, and a truncated bag stayed).
limited() { (trap '' XFSZ; ulimit -f 100; exec "$@"); }
expect "simulate write fails" 1 "big.bag: Error" limited "$bin/simulate" \
  --world "$root/worlds/test_small.yaml" --output "$work/big.bag" --duration 100
expect "offline_slam --output-bag write fails" 1 "res.bag: Error" limited "$bin/offline_slam" \
  --bag "$root/test/data/intel_head.bag" --config "$root/config/laser_fastslam2.yaml" \
  --output "$work/r" --output-bag "$work/r/res.bag" --no-progress --set particles=5
for left in big.bag big.bag.part big.ref.tum big.ref.tum.part r/res.bag r/res.bag.part; do
  [ ! -e "$work/$left" ] || { echo "FAIL: $left left behind by a failed write"; status=1; }
done
# mrclam_to_bag's checks on a whole dataset (a tiny one written here): ground truth that does
# not cover the commands, or no landmark sighting, is refused before anything is written; ground
# truth that begins late or holds a stray pose far away, and commands sharing a stamp, are
# warned about.
ds="$work/mrclam"
mkdir -p "$ds"
printf '# s b\n1 5\n6 63\n' >"$ds/Barcodes.dat"
printf '# s x y sdx sdy\n6 2 0 0.001 0.001\n' >"$ds/Landmark_Groundtruth.dat"
printf '# t v w\n100 0.1 0\n101 0.1 0\n102 0.1 0\n102 0.2 0\n103 0.1 0\n104 0 0\n' \
  >"$ds/Robot1_Odometry.dat"
printf '# t b r b\n101 63 1.5 0.1\n101.5 5 1 0\n' >"$ds/Robot1_Measurement.dat"
truth() { printf '# t x y th\n'; for t in "$@"; do printf '%s 0 0 0\n' "$t"; done; }
truth 99 100 101 102 103 104 105 >"$ds/Robot1_Groundtruth.dat"
expect "mrclam_to_bag tiny dataset" 0 "command\(s\) share the stamp of the one before" \
  "$bin/mrclam_to_bag" "$ds" 1 "$work/tiny.bag"
[ -s "$work/tiny.bag" ] || { echo "FAIL: no tiny.bag"; status=1; }
truth 99 100 101 102 103 104 105 1105 >"$ds/Robot1_Groundtruth.dat"
expect "mrclam_to_bag stray ground truth" 0 "1 stretch\(es\) of more than 10 s without a pose" \
  "$bin/mrclam_to_bag" "$ds" 1 "$work/tiny.bag"
truth 103 104 105 >"$ds/Robot1_Groundtruth.dat"
expect "mrclam_to_bag late ground truth" 0 "Groundtruth.dat begins 3 s after the first command" \
  "$bin/mrclam_to_bag" "$ds" 1 "$work/tiny.bag"
truth 200 201 >"$ds/Robot1_Groundtruth.dat"
expect "mrclam_to_bag ground truth elsewhere" 1 "no ground-truth pose while the commands run" \
  "$bin/mrclam_to_bag" "$ds" 1 "$work/elsewhere.bag"
truth 99 105 >"$ds/Robot1_Groundtruth.dat"
printf '# t b r b\n101.5 5 1 0\n' >"$ds/Robot1_Measurement.dat"
expect "mrclam_to_bag no landmark sighting" 1 "Measurement.dat: no landmark sighting \(1 sightings: 1 of robots" \
  "$bin/mrclam_to_bag" "$ds" 1 "$work/blind.bag"
for left in elsewhere.bag elsewhere.ref.tum blind.bag blind.ref.tum; do
  [ ! -e "$work/$left" ] || { echo "FAIL: $left written although the conversion was refused"; status=1; }
done
# An output path that is a directory, a pipe or a device is not written over (before: a
# finished file was renamed onto it, which replaces /dev/full when run as root and a pipe as
# anyone; a file opened directly at a pipe's path, as mrclam_to_bag's side files were, blocks).
mkdir -p "$work/dir.bag"
expect "simulate onto a directory" 1 "dir.bag: exists and is a directory" "$bin/simulate" \
  --world "$root/worlds/test_small.yaml" --output "$work/dir.bag" --duration 1
mkfifo "$work/pipe.ref.tum"
expect "simulate onto a pipe" 1 "pipe.ref.tum: exists and is a pipe" timeout 60 "$bin/simulate" \
  --world "$root/worlds/test_small.yaml" --output "$work/pipe.bag" --duration 1
expect "offline_slam --output-bag onto a pipe" 1 "pipe.ref.tum: exists and is a pipe" \
  timeout 60 "$bin/offline_slam" --bag "$root/test/data/intel_head.bag" \
  --config "$root/config/laser_fastslam2.yaml" --output "$work/p" \
  --output-bag "$work/pipe.ref.tum" --no-progress --set particles=5
# offline_slam's run directory: every file is checked before the bag is read (before: a pipe at
# summary.json blocked the tool after the whole run, a directory at landmarks.yaml stopped it
# with the files before it written).
mkdir -p "$work/rundir/landmarks.yaml" "$work/rundir2"
mkfifo "$work/rundir2/summary.json"
expect "offline_slam run directory file is a directory" 1 \
  "rundir/landmarks.yaml: exists and is a directory" "$bin/offline_slam" \
  --bag "$root/test/data/intel_head.bag" --config "$root/config/laser_fastslam2.yaml" \
  --output "$work/rundir" --no-progress --set particles=5
expect "offline_slam run directory file is a pipe" 1 "rundir2/summary.json: exists and is a pipe" \
  timeout 60 "$bin/offline_slam" --bag "$root/test/data/intel_head.bag" \
  --config "$root/config/laser_fastslam2.yaml" --output "$work/rundir2" --no-progress \
  --set particles=5
# render_grid's PREFIX.pgm and PREFIX.yaml likewise (before: a pipe there blocked the tool once
# every scan was rendered).
mkfifo "$work/gpipe.yaml"
expect "render_grid output is a pipe" 1 "gpipe.yaml: exists and is a pipe" timeout 60 \
  "$bin/render_grid" --bag "$root/test/data/intel_head.bag" \
  --reference "$root/test/data/intel_head.ref.tum" --config "$root/config/grid_pf_laser.yaml" \
  --output "$work/gpipe"
[ ! -e "$work/gpipe.pgm" ] || { echo "FAIL: gpipe.pgm written although gpipe.yaml was refused"; status=1; }
for dir in rundir rundir2; do
  [ "$(ls "$work/$dir" | wc -l)" -eq 1 ] ||
    { echo "FAIL: $dir: files written although an output was refused: $(ls "$work/$dir")"; status=1; }
done
for left in pipe.bag pipe.bag.part dir.bag.part pipe.ref.tum.part; do
  [ ! -e "$work/$left" ] || { echo "FAIL: $left left behind by a refused output"; status=1; }
done
[ -d "$work/dir.bag" ] && [ -p "$work/pipe.ref.tum" ] ||
  { echo "FAIL: the directory or the pipe was replaced"; status=1; }
expect "validate_bag bad gap" 2 "--max-gap needs a positive number" "$bin/validate_bag" x.bag \
  --max-gap 0
expect "evaluate unlimited gap" 0 "ate" "$bin/evaluate" "$work/a.tum" "$work/a.tum" \
  --interpolate --max-gap inf
expect "validate_bag missing bag" 2 "no_such_input" "$bin/validate_bag" "$missing.bag"
for bag in c.bag m.bag v.bag s.bag; do
  [ ! -e "$work/$bag" ] || { echo "FAIL: $bag written although the conversion failed"; status=1; }
done
# Another bag's reference: few poses match, which is said (the ATE would mean nothing).
expect "offline_slam wrong reference" 0 "only 3 of 90 poses matched a reference pose.*is .*aces_head.ref.tum this bag's reference" \
  "$bin/offline_slam" --bag "$root/test/data/intel_head.bag" --config "$laser_config" \
  --output "$work/wrongref" --reference "$root/test/data/aces_head.ref.tum" --no-progress
# /tf_static is latched in the bags the tools write (simulate, offline_slam --output-bag; and
# carmen_to_bag, as before), so that rviz or a node started after `rosbag play` began gets the mounts.
"$bin/simulate" --world "$root/worlds/test_small.yaml" --output "$work/latch.bag" --seed 1 \
  --duration 10 >/dev/null
"$bin/offline_slam" --bag "$work/latch.bag" --config "$laser_config" --output "$work/latch" \
  --output-bag "$work/latch_out.bag" --no-progress --set particles=5 >/dev/null 2>&1 ||
  { echo "FAIL: offline_slam --output-bag on latch.bag"; status=1; }
/usr/bin/python3 - "$work/latch.bag" "$work/latch_out.bag" <<'PY' || status=1
import os, sys
import rosbag
for path in sys.argv[1:]:
    if not os.path.exists(path):
        sys.exit("FAIL: %s was not written" % path)
    with rosbag.Bag(path) as bag:
        latched = [c.header.get("latching") for c in bag._get_connections(topics=["/tf_static"])]
    if not latched or any(flag != b"1" for flag in latched):
        sys.exit("FAIL: %s: /tf_static not latched (%s)" % (path, latched))
print("ok: /tf_static latched in the written bags")
PY
[ "$status" -eq 0 ] && echo PASS
exit "$status"
