#!/usr/bin/env bash
# The Python benchmark tools on bad input: a missing or malformed trajectory, log, results file,
# world or argument exits non-zero with a message naming the file (and line) or the argument,
# never with a Python traceback (increment_errors, grid_pf_study.py --from-json, run_experiments,
# carmen_icp_check, run_dpf); and the good cases still run.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
source "$(dirname "$0")/lib/expect.sh"
export PATH=/usr/bin:$PATH
b="$root/benchmarks"
status=0

# clean NAME WANTED_STATUS PATTERN COMMAND...: expect, and no traceback in the output.
clean() {
  expect "$@"
  if grep -q Traceback "$work/out"; then
    echo "FAIL: $1: a Python traceback"; sed 's/^/  /' "$work/out"; status=1
  fi
}

printf '# t x y z qx qy qz qw\n0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n2 2 0 0 0 0 0.0998 0.995\n' >"$work/ref.tum"
printf '0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\nbad line\n' >"$work/short_line.tum"
printf '0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n2 2 0 0 0 0 x 1\n' >"$work/word.tum"
printf '0 0 0 0 0 0 0 1\n1 nan 0 0 0 0 0 1\n' >"$work/nan.tum"
printf '0 0 0 0 0 0 0 0\n' >"$work/zero_q.tum"
: >"$work/empty.tum"
# The same poses with an unnormalised quaternion (x 2): the same headings.
printf '0 0 0 0 0 0 0 2\n1 1 0 0 0 0 0 2\n2 2 0 0 0 0 0.1996 1.99\n' >"$work/scaled.tum"

clean "increment_errors: a missing file" 1 'increment_errors: .*no_such.tum: cannot read trajectory: No such file' \
  "$b/increment_errors" "$work/no_such.tum" "$work/ref.tum"
clean "increment_errors: a line of 2 fields" 1 'short_line.tum:3: expected 8 numbers .*got 2' \
  "$b/increment_errors" "$work/short_line.tum" "$work/ref.tum"
clean "increment_errors: a word" 1 "word.tum:3: not a number in '2 2 0 0 0 0 x 1'" \
  "$b/increment_errors" "$work/ref.tum" "$work/word.tum"
clean "increment_errors: NaN" 1 'nan.tum:2: non-finite value' \
  "$b/increment_errors" "$work/ref.tum" "$work/nan.tum"
clean "increment_errors: a zero quaternion" 1 'zero_q.tum:1: quaternion is zero' \
  "$b/increment_errors" "$work/zero_q.tum" "$work/ref.tum"
clean "increment_errors: an empty file" 1 'empty.tum: 0 poses, need at least 1' \
  "$b/increment_errors" "$work/empty.tum" "$work/ref.tum"
clean "increment_errors: an unnormalised quaternion reads as the normalised one" 0 \
  'accumulated dtheta error 0\.00 deg' "$b/increment_errors" "$work/ref.tum" "$work/scaled.tum"

# grid_pf_study.py --from-json: report() on a run's JSON, and broken ones.
printf '{"w": {"series": {"100": [[0.1, 0.2], [0.1, 0.1]], "odometry": [[0.2, 0.3], [0.2, 0.2]]}, "seeds": 2, "wall_s_mean": {"100": 1.0}, "peak_rss_mb_max": {"100": 10}}}\n' >"$work/study.json"
printf '{"w": {"series": {"odometry": [[0.1], []]}, "seeds": 1, "wall_s_mean": {}, "peak_rss_mb_max": {}}}\n' >"$work/empty_series.json"
printf '{"w": {"series": {}}}\n' >"$work/no_seeds.json"
printf 'nope\n' >"$work/not_json.json"
clean "grid_pf_study: a short run (fewer than 601 steps) reports n/a" 0 \
  '\| 100 particles \| 0\.2000 / 0\.1000 .*\| n/a \| n/a \|' \
  "$b/grid_pf_study.py" --from-json "$work/study.json" --output "$work/study"
clean "grid_pf_study: a missing file" 1 'cannot read .*no_such.json: No such file' \
  "$b/grid_pf_study.py" --from-json "$work/no_such.json" --output "$work/study"
clean "grid_pf_study: not JSON" 1 'not_json.json is not JSON' \
  "$b/grid_pf_study.py" --from-json "$work/not_json.json" --output "$work/study"
clean "grid_pf_study: a world without seeds" 1 "no_seeds.json: world 'w' lacks 'seeds'" \
  "$b/grid_pf_study.py" --from-json "$work/no_seeds.json" --output "$work/study"
printf '{"w": {"series": {"odometry": [[0.1], [0.1]]}, "seeds": "ten", "wall_s_mean": {}, "peak_rss_mb_max": {}}}\n' >"$work/word_seeds.json"
clean "grid_pf_study: seeds that are not a number" 1 "world 'w': 'seeds' is not a whole number" \
  "$b/grid_pf_study.py" --from-json "$work/word_seeds.json" --output "$work/study"
clean "grid_pf_study: an empty series" 1 "series 'odometry' is not two non-empty lists of numbers" \
  "$b/grid_pf_study.py" --from-json "$work/empty_series.json" --output "$work/study"

# run_experiments: a world or config that is not YAML, or not a mapping, is named before any run.
printf 'sensors: [a\n' >"$work/broken_world.yaml"
printf -- '- 1\n- 2\n' >"$work/list_world.yaml"
clean "run_experiments: a world that is not YAML" 1 'world .*broken_world.yaml is not valid YAML' \
  "$b/run_experiments" --worlds "$work/broken_world.yaml" --configs laser_fastslam2 --seeds 1 \
  --out "$work/re" --bin-dir "$bin"
clean "run_experiments: a world that is a list" 1 'list_world.yaml: the top level is a list, not a mapping' \
  "$b/run_experiments" --worlds "$work/list_world.yaml" --configs laser_fastslam2 --seeds 1 \
  --out "$work/re" --bin-dir "$bin"

# carmen_icp_check: the log is read and checked before any matching.
printf 'FLASER 3 1 2\n' | gzip >"$work/short.log.gz"
printf 'FLASER 3 1 2 3 0 0 0\n' >"$work/one.log"
printf 'FLASER 3 1 2 3 0 0 0\nFLASER 3 1 inf 3 0 0 0\n' >"$work/inf.log"
clean "carmen_icp_check: a missing log" 1 'cannot read .*no_such.log.gz: No such file' \
  "$b/carmen_icp_check" "$work/no_such.log.gz"
clean "carmen_icp_check: a text file named .gz" 1 'cannot read .*ref.tum.gz' \
  bash -c "cp '$work/ref.tum' '$work/ref.tum.gz' && '$b/carmen_icp_check' '$work/ref.tum.gz'"
clean "carmen_icp_check: a FLASER line cut short" 1 'short.log.gz:1: malformed FLASER line \(3 beams announced, 4 fields\)' \
  "$b/carmen_icp_check" "$work/short.log.gz"
clean "carmen_icp_check: one scan" 1 'one.log holds 1 FLASER scans, need at least 2' \
  "$b/carmen_icp_check" "$work/one.log"
clean "carmen_icp_check: inf in a scan" 1 'inf.log:2: non-finite FLASER value' \
  "$b/carmen_icp_check" "$work/inf.log"

# run_dpf: its arguments are checked before any run (argparse's usage error, status 2).
clean "run_dpf: --bag without NAME=" 2 "--bag: expected NAME=BAG\[,REF.tum\], got '$work/x.bag'" \
  "$b/run_dpf" --bag "$work/x.bag" --out "$work/dpf"
clean "run_dpf: --bag with a missing bag" 2 "--bag: no file $work/x.bag" \
  "$b/run_dpf" --bag "x=$work/x.bag" --out "$work/dpf"
clean "run_dpf: --bag with a missing reference" 2 "--bag: no file $work/no_ref.tum" \
  "$b/run_dpf" --bag "x=$work/ref.tum,$work/no_ref.tum" --out "$work/dpf"
clean "run_dpf: a word in --seeds" 2 "--seeds: expected whole numbers separated by commas, got '1,a'" \
  "$b/run_dpf" --seeds 1,a --out "$work/dpf"
clean "run_dpf: an unknown run" 2 '--runs: unknown foo \(known: fastslam2,' \
  "$b/run_dpf" --runs dpf,foo --out "$work/dpf"
clean "run_dpf: a missing world" 2 "--world: no file $work/no_world.yaml" \
  "$b/run_dpf" --world "$work/no_world.yaml" --out "$work/dpf"
clean "run_dpf: a --bin-dir without the tools" 2 "--bin-dir: $work lacks offline_slam or simulate" \
  "$b/run_dpf" --bin-dir "$work" --out "$work/dpf"
exit $status
