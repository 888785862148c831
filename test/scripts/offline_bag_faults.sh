#!/usr/bin/env bash
# offline_slam and validate_bag on copies of a simulated bag with one fault each, as converters,
# drivers and recorders make them. Fails unless each run ends normally and names the fault:
#   compressed  bag (record) times squeezed 100x, header stamps jumping 200 s forward half way:
#               every frame still has tf (the tf buffer kept bag duration + 60 s of stamps and
#               dropped the first half)
#   hugestamp   one scan stamped 4294967295 s (a driver's -1): that frame is lost, not the run;
#               likewise one odometry transform so stamped (no second tf segment), and a scan
#               recorded at that bag time (offline_slam and validate_bag used to throw)
#   farscan     one scan stamped 3.9e9 s (over 2^31 s from the odometry): lost, and said why
#   empty       no messages: both tools say so, naming the file
#   swap        every 5th scan stamped after the next: the rejected frames are counted and the
#               first named (they used to be silent)
#   denorm      odometry quaternions of norm 1.02, which tf2 refuses: named by both tools
#   jumpback    the clock goes back 100 s half way: the restart and the poses it discards are said
#   anglemax    angle_max inconsistent with the beams: warned once, the scans still used
#   featnan     one NaN point per FeatureArray: counted by offline_slam, reported by validate_bag
#   sonar       per-transducer Range readings: those that join the echo window are counted as
#               buffered, not as skipped for lack of motion
#   badindex    one chunk index entry pointing past its chunk, and one at a spot inside it where
#               no record fits: rosbag itself read outside its buffer and the tools died by
#               SIGSEGV; now both refuse the bag, naming the entry
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam validate_bag

"$bin/simulate" --world "$root/worlds/test_small.yaml" --output "$work/clean.bag" --seed 4 >/dev/null
/usr/bin/python3 - "$work" <<'PY'
import copy
import sys

import rosbag
import rospy

work = sys.argv[1]
messages = list(rosbag.Bag(work + "/clean.bag").read_messages())
t0 = messages[0][2]


def write(name, edit):
    with rosbag.Bag("%s/%s.bag" % (work, name), "w") as out:
        for i, (topic, msg, t) in enumerate(messages):
            for topic2, msg2, t2 in edit(i, topic, copy.deepcopy(msg), t):
                out.write(topic2, msg2, t2)


def squeezed(i, topic, msg, t):
    # Stamps also jump 200 s forward half way: they span 261 s in 0.6 s of bag time.
    if t > t0 + rospy.Duration.from_sec(30.0) and topic != "/tf_static":
        ahead = rospy.Duration.from_sec(200.0)
        if hasattr(msg, "transforms"):
            for tr in msg.transforms:
                tr.header.stamp += ahead
        elif hasattr(msg, "header"):
            msg.header.stamp += ahead
    yield topic, msg, t0 + rospy.Duration.from_sec((t - t0).to_sec() / 100.0)


scans = [0]


def hugestamp(i, topic, msg, t):
    if topic == "/scan":
        scans[0] += 1
        if scans[0] == 40:
            msg.header.stamp = rospy.Time(4294967295, 0)
    yield topic, msg, t


def farscan(i, topic, msg, t):
    if topic == "/scan":
        scans[0] += 1
        if scans[0] == 40:  # far from the data, but not near 2^32 s
            msg.header.stamp = rospy.Time(3900000000, 0)
    yield topic, msg, t


def farodom(i, topic, msg, t):
    if topic == "/tf":
        scans[0] += 1
        if scans[0] == 300:  # half way
            for tr in msg.transforms:
                tr.header.stamp = rospy.Time(4294967295, 0)
    yield topic, msg, t


def farbagtime(i, topic, msg, t):
    if topic == "/scan":
        scans[0] += 1
        if scans[0] == 40:
            msg.header.stamp = rospy.Time(4294967295, 0)
            t = msg.header.stamp
    yield topic, msg, t


def swap(i, topic, msg, t):
    if topic == "/scan":
        scans[0] += 1
        if scans[0] % 5 == 0:
            msg.header.stamp += rospy.Duration.from_sec(0.3)  # scans are 0.2 s apart
    yield topic, msg, t


def denorm(i, topic, msg, t):
    if topic == "/tf":
        for tr in msg.transforms:
            for k in "xyzw":
                setattr(tr.transform.rotation, k, 1.02 * getattr(tr.transform.rotation, k))
    yield topic, msg, t


half = t0 + rospy.Duration.from_sec(30.0)


def jumpback(i, topic, msg, t):
    if t > half and topic != "/tf_static":
        back = rospy.Duration.from_sec(100.0)
        if hasattr(msg, "transforms"):
            for tr in msg.transforms:
                tr.header.stamp -= back
        elif hasattr(msg, "header"):
            msg.header.stamp -= back
    yield topic, msg, t


def anglemax(i, topic, msg, t):
    if topic == "/scan":
        msg.angle_max += 0.5
    yield topic, msg, t


def featnan(i, topic, msg, t):
    if topic == "/features" and msg.points:
        msg.points[0].range = float("nan")
    yield topic, msg, t


scans[0] = 0
write("compressed", squeezed)
scans[0] = 0
write("hugestamp", hugestamp)
scans[0] = 0
write("farscan", farscan)
scans[0] = 0
write("farbagtime", farbagtime)
scans[0] = 0
write("farodom", farodom)
scans[0] = 0
write("swap", swap)
write("denorm", denorm)
write("jumpback", jumpback)
write("anglemax", anglemax)
write("featnan", featnan)
rosbag.Bag(work + "/empty.bag", "w").close()
PY
# Damaged chunk indexes, written byte by byte (format 2.0: records of header length, fields
# "name=value", data length, data; index records (op 4) hold 12-byte entries: time, offset).
/usr/bin/python3 - "$work" <<'PY'
import struct
import sys

work = sys.argv[1]
data = bytearray(open(work + "/clean.bag", "rb").read())


def first_index_entry():
    at = 13
    while at < len(data):
        (header_len,) = struct.unpack_from("<I", data, at)
        header = bytes(data[at + 4:at + 4 + header_len])
        (data_len,) = struct.unpack_from("<I", data, at + 4 + header_len)
        fields, p = {}, 0
        while p < header_len:
            (n,) = struct.unpack_from("<I", header, p)
            name, _, value = header[p + 4:p + 4 + n].partition(b"=")
            fields[name] = value
            p += 4 + n
        if fields.get(b"op") == b"\x04":
            return at + 8 + header_len + 8  # the first entry's offset field
        at += 8 + header_len + data_len
    raise SystemExit("no index record in clean.bag")


offset_at = first_index_entry()
for name, offset in (("badindex_past", 0xFFFFFFF0), ("badindex_inside", 3)):
    broken = bytearray(data)
    struct.pack_into("<I", broken, offset_at, offset)
    open("%s/%s.bag" % (work, name), "wb").write(broken)
PY

failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
# run NAME CONFIG [--set ...]: offline_slam on NAME.bag; stderr in NAME.err, exit status in $rc.
run() {
  local name=$1 config=$2
  shift 2
  rc=0
  "$bin/offline_slam" --bag "$work/$name.bag" --config "$root/config/$config.yaml" --no-progress \
    --set particles=10 --output "$work/out_$name" "$@" >"$work/$name.out" 2>"$work/$name.err" || rc=$?
}
field() { /usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" \
  "$work/out_$1/summary.json" "$2"; }
expect_err() {  # NAME TEXT: offline_slam's stderr for NAME holds TEXT
  grep -qF -- "$2" "$work/$1.err" || { fail "$1: stderr lacks '$2':"; cat "$work/$1.err"; }
}
validate() {  # NAME TEXT: validate_bag reports NAME.bag's fault with TEXT (exit 1)
  local vrc=0
  "$bin/validate_bag" "$work/$1.bag" >"$work/$1.val" 2>&1 || vrc=$?
  [ "$vrc" -eq 1 ] || { fail "validate_bag $1: exit $vrc (want 1)"; cat "$work/$1.val"; }
  grep -qF -- "$2" "$work/$1.val" || { fail "validate_bag $1 lacks '$2':"; cat "$work/$1.val"; }
}

run clean laser_fastslam2
[ "$rc" -eq 0 ] || fail "clean: exit $rc"
clean_updates=$(field clean updates)
[ "$clean_updates" -gt 200 ] || fail "clean: only $clean_updates updates"

run compressed laser_fastslam2
[ "$rc" -eq 0 ] || fail "compressed: exit $rc"
[ "$(field compressed dropped_no_tf)" -eq 0 ] || fail "compressed: $(field compressed dropped_no_tf) frames without tf"
[ "$(field compressed updates)" -ge $((clean_updates - 5)) ] ||
  fail "compressed: $(field compressed updates) updates against $clean_updates"

run hugestamp laser_fastslam2
[ "$rc" -eq 0 ] || { fail "hugestamp: exit $rc"; cat "$work/hugestamp.err"; }
[ -f "$work/out_hugestamp/summary.json" ] && [ "$(field hugestamp dropped_bad_message)" -eq 1 ] &&
  [ "$(field hugestamp dropped_no_tf)" -eq 0 ] || fail "hugestamp: the far stamp's frame was not the one dropped"
expect_err hugestamp "/scan: stamp 4294967295.000 s is near 2^32 s"
validate hugestamp "/scan: 1 stamp(s) near 2^32 s"
# A scan stamped 3.9e9 s is not near 2^32 s, but more than 2^31 s from the odometry: tf2's
# time arithmetic throws (ros::Duration). That frame is dropped without tf, and said so.
run farscan laser_fastslam2
[ "$rc" -eq 0 ] || { fail "farscan: exit $rc"; cat "$work/farscan.err"; }
[ "$(field farscan dropped_no_tf)" -eq 1 ] || fail "farscan: $(field farscan dropped_no_tf) frames without tf"
expect_err farscan "at 3900000000.000: the stamp is too far from the bag's transforms for tf2's time arithmetic"
# ... and the same far stamp on one odometry transform, and as the bag time of that scan (a
# converter that records at the header stamps): still one frame lost, not the run or the tf.
run farodom laser_fastslam2
[ "$rc" -eq 0 ] || { fail "farodom: exit $rc"; cat "$work/farodom.err"; }
[ "$(field farodom tf_segments)" -eq 1 ] || fail "farodom: the far odometry stamp split the tf"
[ "$(field farodom dropped_no_tf)" -le 2 ] || fail "farodom: $(field farodom dropped_no_tf) frames without tf"
expect_err farodom "near 2^32 s"
run farbagtime laser_fastslam2
[ "$rc" -eq 0 ] || { fail "farbagtime: exit $rc"; cat "$work/farbagtime.err"; }
vrc=0
"$bin/validate_bag" "$work/farbagtime.bag" >"$work/farbagtime.val" 2>&1 || vrc=$?
[ "$vrc" -eq 1 ] || { fail "validate_bag farbagtime: exit $vrc"; cat "$work/farbagtime.val"; }

# open_bag TOOL NAME: offline_slam or validate_bag on NAME.bag; output in NAME.err, status in $erc.
open_bag() {
  erc=0
  if [ "$1" = offline_slam ]; then
    "$bin/offline_slam" --bag "$work/$2.bag" --config "$root/config/laser_fastslam2.yaml" \
      --output "$work/out_$2" >"$work/$2.err" 2>&1 || erc=$?
  else
    "$bin/validate_bag" "$work/$2.bag" >"$work/$2.err" 2>&1 || erc=$?
  fi
}

for tool in offline_slam validate_bag; do
  open_bag "$tool" empty
  [ "$erc" -ne 0 ] || fail "empty: $tool exited 0"
  grep -qF "$work/empty.bag: the bag holds no messages" "$work/empty.err" ||
    { fail "empty: $tool's message:"; cat "$work/empty.err"; }
done

for name in badindex_past badindex_inside; do
  for tool in offline_slam validate_bag; do
    open_bag "$tool" "$name"
    { [ "$erc" -ne 0 ] && [ "$erc" -lt 128 ]; } || fail "$name: $tool exited $erc"
    grep -qF "$work/$name.bag: the bag is damaged (index entry 1 of the record at byte" \
      "$work/$name.err" || { fail "$name: $tool's message:"; cat "$work/$name.err"; }
  done
done

run swap laser_fastslam2
[ "$(field swap rejected)" -gt 0 ] || fail "swap: nothing rejected"
expect_err swap "frame(s) were not used"
expect_err swap "the first: /scan at"

run denorm laser_fastslam2
expect_err denorm "unusable transform(s); the first: /tf odom -> base_link"
expect_err denorm "not normalised (norm 1.02)"
validate denorm "unusable transform(s) (the first: a quaternion that is not normalised"

run jumpback laser_fastslam2
[ "$(field jumpback resets)" -eq 1 ] || fail "jumpback: $(field jumpback resets) resets"
discarded=$(field jumpback discarded_poses)
[ "$discarded" -gt 50 ] || fail "jumpback: $discarded poses discarded"
expect_err jumpback "the session started a new map"
expect_err jumpback "$discarded pose(s) of the runs before are not in them"

run anglemax laser_fastslam2
[ "$(field anglemax updates)" -eq "$clean_updates" ] || fail "anglemax: the scans were not used"
[ "$(grep -c "does not span angle_min..angle_max" "$work/anglemax.err")" -eq 1 ] ||
  { fail "anglemax: not warned exactly once"; cat "$work/anglemax.err"; }

run featnan landmarks_fastslam2 --set ensemble.members=1 --set smoothing.enabled=false
[ "$(field featnan dropped_features)" -gt 200 ] || fail "featnan: $(field featnan dropped_features) dropped"
expect_err featnan "unusable feature(s) (non-finite values or covariance, or a negative range)"
validate featnan "/features: "
grep -qF "unusable feature(s)" "$work/featnan.val" || fail "featnan: validate_bag's wording"

cp "$work/clean.bag" "$work/sonar.bag"
run sonar sonar_fastslam2
buffered=$(field sonar sonar_buffered)
[ "$buffered" -gt 1000 ] || fail "sonar: $buffered readings buffered"
[ "$(field sonar skipped_no_motion)" -lt "$buffered" ] || fail "sonar: readings counted as skipped"

if [ "$failures" -gt 0 ]; then
  echo "FAIL: $failures check(s)"
  exit 1
fi
echo "PASS: offline_slam and validate_bag name every fault (clean: $clean_updates updates;" \
  "jumpback discarded $discarded poses; sonar buffered $buffered readings)"
