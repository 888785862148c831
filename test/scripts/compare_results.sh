#!/usr/bin/env bash
# benchmarks/compare_results on small hand-made run_experiments outputs: the ratio of the mean
# final position errors; a failed run counted as such ("4 of 5 (1 failed)") and left out; a NaN
# landmark error left out and counted ("(1 n/a)"); a config whose runs all failed, a file that
# is not JSON, a run_mrclam results file, an ok run without a final error and a missing file
# exit 1 naming what (no traceback).
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
source "$(dirname "$0")/lib/expect.sh"
compare="$root/benchmarks/compare_results"
status=0

# runs OUT CONFIG FINAL_ERRORS [EDIT]: results.json of world w1, seeds 1..n, with these final
# position errors; EDIT (python on the list `runs`) breaks it.
runs() {
  /usr/bin/python3 - "$@" <<'PY'
import json, sys
out, config, errors = sys.argv[1], sys.argv[2], [float(e) for e in sys.argv[3].split(",")]
edit = sys.argv[4] if len(sys.argv) > 4 else ""
runs = [{"world": "w1", "config": config, "seed": s + 1, "status": "ok",
         "final_position_error_m": e, "final_heading_error_deg": 1.0, "ate_rmse_m": e,
         "point_landmarks": 5, "landmark_error_m": 0.1} for s, e in enumerate(errors)]
exec(edit)
with open(out, "w") as f:
    json.dump({"runs": runs}, f, allow_nan=True)
PY
}
runs "$work/base.json" fs2 0.2,0.2,0.2,0.2,0.2
runs "$work/cand.json" robust 0.1,0.1,0.1,0.1,0.3
runs "$work/failed.json" robust 0.1,0.1,0.1,0.1,0.3 \
  'runs[4]["status"] = "failed"; del runs[4]["final_position_error_m"]'
runs "$work/nan.json" robust 0.1,0.1,0.1,0.1,0.3 'runs[0]["landmark_error_m"] = float("nan")'
runs "$work/allfailed.json" robust 0.1,0.1 'for r in runs: r["status"] = "failed"'
runs "$work/nofinal.json" robust 0.1,0.1 'del runs[1]["final_position_error_m"]'
printf '{"runs": [{"robot": 1, "seed": 1, "ate_m": 0.1}]}\n' >"$work/mrclam.json"
: >"$work/empty.json"

expect "the ratio of the means, 0.14 / 0.2" 0 '\| w1 \| robust \| 5 \| 0\.140 ± 0\.089 .*\| 0\.70 \|' \
  "$compare" "$work/base.json" "$work/cand.json"
expect "a failed run counted and left out (ratio 0.1 / 0.2)" 0 \
  '\| w1 \| robust \| 4 of 5 \(1 failed\) \| 0\.100 ± 0\.000 .*\| 0\.50 \|' \
  "$compare" "$work/base.json" "$work/failed.json"
expect "a NaN landmark error left out and counted" 0 '\| 0\.100 ± 0\.000 \(1 n/a\) \|' \
  "$compare" "$work/base.json" "$work/nan.json"
expect "every run of a config failed" 1 'every run of w1 robust in .*allfailed.json failed' \
  "$compare" "$work/base.json" "$work/allfailed.json"
expect "an ok run without a final error" 1 'nofinal.json: run 1 \(w1, robust, seed 2\) is ok but has no finite final_position_error_m' \
  "$compare" "$work/base.json" "$work/nofinal.json"
expect "a run_mrclam results file" 1 'mrclam.json: run 0 has no world or config' \
  "$compare" "$work/base.json" "$work/mrclam.json"
expect "an empty file" 1 'empty.json: not JSON' "$compare" "$work/base.json" "$work/empty.json"
expect "a missing file" 1 'no_such.json: No such file' "$compare" "$work/no_such.json" "$work/cand.json"
exit $status
