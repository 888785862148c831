#!/usr/bin/env bash
# Issue 6's simulated comparison as a regression test (docs/results.md, "Session 18"): Havangi
# et al.'s car (worlds/havangi_car.yaml, known association, 100 particles) through
# benchmarks/run_experiments, seeds 1-20, FastSLAM 2.0 against H-infinity FastSLAM, each told the
# wrong measurement noise (sigma_r 0.7 m, sigma_b 1 deg; truth 0.1 m, 0.1 deg) and the right one.
# Fails unless H-infinity's mean ATE is at most 0.62 of FastSLAM 2.0's with the wrong noise and
# at most 1.2 of it with the right noise (the issue's 0.6 and 1.2 over 10 seeds; 20 seeds here,
# as the ratio of 10 varies by +-0.1 from block to block), and, so that a worse FastSLAM 2.0
# cannot hide a worse H-infinity, unless H-infinity's own mean ATE is at most 0.25 m with either
# noise. Measured: 0.58 and 0.71, 0.206 and 0.233 m as shipped; with the EKF's draw (--set
# hinf.proposal_covariance=ekf, sessions 14-17) 0.68 and 0.76, 0.239 and 0.249 m, and it fails.
# About 15 s. Extra arguments go to run_experiments; KEEP_WORK=1 keeps the runs.
set -euo pipefail

source "$(dirname "$0")/lib/offline.sh"
require_tools simulate offline_slam evaluate

if ! /usr/bin/python3 "$root/benchmarks/run_experiments" --bin-dir "$bin" --worlds havangi_car \
    --seeds 20 --jobs 2 --report '' --out "$work" "$@" >"$work/run.log" 2>&1; then
  tail -20 "$work/run.log"
  echo "FAIL: run_experiments failed; log under $work (rerun with KEEP_WORK=1 to keep it)"
  exit 1
fi

/usr/bin/python3 - "$work/results.json" <<'PY'
import json
import math
import sys

results = json.load(open(sys.argv[1]))
runs = results["runs"]
# The ratios as run_experiments computed them (its "comparisons"), for 20 runs of each config.
comparisons = {c["title"]: c for c in results.get("comparisons", [])}

failed = False
for noise, limit in (("wrong R", 0.62), ("right R", 1.2)):
    for config in ("hinf_fastslam, " + noise, "fastslam2, " + noise):
        values = [r["ate_rmse_m"] for r in runs if r["config"] == config]
        if len(values) != 20 or not all(v is not None and math.isfinite(v) for v in values):
            sys.exit("FAIL: expected 20 runs of '%s' with a finite ATE, got %s" % (config, values))
    title = "H-infinity / FastSLAM 2.0 ATE, " + noise
    if title not in comparisons:
        sys.exit("FAIL: run_experiments wrote no comparison '%s' to results.json" % title)
    c = comparisons[title]
    ratio, hinf = c["ratio"], c["numerator_ate_m"]
    ok = ratio <= limit and hinf <= 0.25
    failed = failed or not ok
    print("car, seeds 1-20, %s: H-infinity / FastSLAM 2.0 ATE %.3f (at most %.2f), H-infinity "
          "ATE %.3f m (at most 0.25)%s" % (noise, ratio, limit, hinf, "" if ok else "  <- FAIL"))
print("FAIL" if failed else "PASS")
sys.exit(1 if failed else 0)
PY
