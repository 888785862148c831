#!/usr/bin/python3
"""Checks benchmarks/run_mrclam's results.json against issue-6 style limits.

usage: mrclam_check.py RESULTS.json --runs N [--min-halved N] [--max-mean-ratio X]
                       [--min-clean N] [--max-spurious X] [--min-within N] [--min-all-three N]
                       [--hint TEXT ...]

Figures over the runs: ATE at most half the odometry's ("halved"), the mean of ATE / odometry
ATE, runs with at most 2 spurious landmarks ("clean"), spurious landmarks per run, runs with
every matched landmark within 0.3 m ("within") and runs meeting those three targets at once.
Prints them with their limits, then PASS, or each figure outside its limit, the hints (what
such a failure has meant before) and exits 1.
"""

import argparse
import json
import math
import sys


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("results")
    parser.add_argument("--runs", type=int, required=True, help="runs expected")
    parser.add_argument("--min-halved", type=int, default=0)
    parser.add_argument("--max-mean-ratio", type=float, default=math.inf)
    parser.add_argument("--min-clean", type=int, default=0)
    parser.add_argument("--max-spurious", type=float, default=math.inf)
    parser.add_argument("--min-within", type=int, default=0)
    parser.add_argument("--min-all-three", type=int, default=0)
    parser.add_argument("--hint", action="append", default=[],
                        help="printed on failure (repeatable)")
    a = parser.parse_args(argv)
    runs = json.load(open(a.results))
    runs = runs["runs"] if isinstance(runs, dict) else runs
    ratios = [r["ate_ratio"] for r in runs]
    if len(ratios) != a.runs or not all(math.isfinite(r) for r in ratios):
        print("FAIL: expected %d runs with a finite ATE ratio, got %d: %s"
              % (a.runs, len(ratios), ratios))
        return 1
    halved = [r["ate_ratio"] <= 0.5 for r in runs]
    clean = [r["spurious"] <= 2 for r in runs]
    within = [r["max_err_m"] <= 0.3 for r in runs]  # NaN (nothing matched) counts as not within
    figures = [  # (name, value, limit, True when the value is within it)
        ("runs with the odometry's ATE halved", sum(halved), ">= %d" % a.min_halved,
         sum(halved) >= a.min_halved),
        ("mean ATE / odometry ATE", sum(ratios) / len(ratios), "<= %g" % a.max_mean_ratio,
         sum(ratios) / len(ratios) <= a.max_mean_ratio),
        ("runs with <= 2 spurious landmarks", sum(clean), ">= %d" % a.min_clean,
         sum(clean) >= a.min_clean),
        ("spurious landmarks per run", sum(r["spurious"] for r in runs) / len(runs),
         "<= %g" % a.max_spurious,
         sum(r["spurious"] for r in runs) / len(runs) <= a.max_spurious),
        ("runs with every matched landmark within 0.3 m", sum(within), ">= %d" % a.min_within,
         sum(within) >= a.min_within),
        ("runs meeting all three targets", sum(h and c and w for h, c, w in zip(halved, clean, within)),
         ">= %d" % a.min_all_three,
         sum(h and c and w for h, c, w in zip(halved, clean, within)) >= a.min_all_three),
    ]
    unchecked = {">= 0", "<= inf"}
    failed = False
    for name, value, limit, ok in figures:
        limit = "not checked" if limit in unchecked else limit
        shown = "%.2f" % value if isinstance(value, float) else str(value)
        print("%s: %s (%s)%s" % (name, shown, limit, "" if ok else "  <- FAIL"))
        failed = failed or not ok
    if failed:
        for hint in a.hint:
            print("hint: " + hint)
    print("FAIL" if failed else "PASS")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
