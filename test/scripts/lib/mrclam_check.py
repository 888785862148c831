#!/usr/bin/python3
"""Checks benchmarks/run_mrclam's results.json against issue-6 style limits.

usage: mrclam_check.py RESULTS.json --runs N [--filter] [--min-halved N] [--max-mean-ratio X]
                       [--min-clean N] [--max-spurious X] [--min-within N] [--min-all-three N]
                       [--max-copy-pairs N] [--max-close-pairs N] [--hint TEXT ...]

Figures over the runs: ATE at most half the odometry's ("halved"), the mean of ATE / odometry
ATE, runs with at most 2 spurious landmarks ("clean"), spurious landmarks per run, runs with
every matched landmark within 0.3 m ("within"), runs meeting those three targets at once, the
pairs of copies of one landmark in the final maps (run_mrclam's copy_pairs: within chi2 9.21 of
each other, both seen at least 10 times; summed) and every pair within chi2 9.21 of each other,
young ones included (close_pairs, summed). With --filter the figures are those of each run's
"filter" record: the filter's own path and map when the config smooths them after the run.
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
    parser.add_argument("--filter", action="store_true",
                        help="check the filter's own path and map (smoothing.enabled runs)")
    parser.add_argument("--min-halved", type=int)
    parser.add_argument("--max-mean-ratio", type=float)
    parser.add_argument("--min-clean", type=int)
    parser.add_argument("--max-spurious", type=float)
    parser.add_argument("--min-within", type=int)
    parser.add_argument("--min-all-three", type=int)
    parser.add_argument("--max-copy-pairs", type=int)
    parser.add_argument("--max-close-pairs", type=int)
    parser.add_argument("--hint", action="append", default=[],
                        help="printed on failure (repeatable)")
    a = parser.parse_args(argv)
    runs = json.load(open(a.results))
    runs = runs["runs"] if isinstance(runs, dict) else runs
    if a.filter:
        if not all("filter" in r for r in runs):
            print("FAIL: --filter, but some runs have no filter record (smoothing.enabled off?)")
            return 1
        runs = [r["filter"] for r in runs]
        print("the filter's own path and map (before smoothing):")
    ratios = [r["ate_ratio"] for r in runs]
    if len(ratios) != a.runs or not all(math.isfinite(r) for r in ratios):
        print("FAIL: expected %d runs with a finite ATE ratio, got %d: %s"
              % (a.runs, len(ratios), ratios))
        return 1
    halved = [r["ate_ratio"] <= 0.5 for r in runs]
    clean = [r["spurious"] <= 2 for r in runs]
    within = [r["max_err_m"] <= 0.3 for r in runs]  # NaN (nothing matched) counts as not within
    all_three = [h and c and w for h, c, w in zip(halved, clean, within)]
    figures = [  # (name, value, at least (True) or at most, limit; None: not checked)
        ("runs with the odometry's ATE halved", sum(halved), True, a.min_halved),
        ("mean ATE / odometry ATE", sum(ratios) / len(ratios), False, a.max_mean_ratio),
        ("runs with <= 2 spurious landmarks", sum(clean), True, a.min_clean),
        ("spurious landmarks per run", sum(r["spurious"] for r in runs) / len(runs), False,
         a.max_spurious),
        ("runs with every matched landmark within 0.3 m", sum(within), True, a.min_within),
        ("runs meeting all three targets", sum(all_three), True, a.min_all_three),
        ("copy pairs in the final maps",
         sum(r.get("copy_pairs", float("nan")) for r in runs), False, a.max_copy_pairs),
        ("close pairs in the final maps (young ones too)",
         sum(r.get("close_pairs", float("nan")) for r in runs), False, a.max_close_pairs),
    ]
    failed = False
    for name, value, at_least, limit in figures:
        shown = "%.2f" % value if isinstance(value, float) else str(value)
        if limit is None:
            print("%s: %s (not checked)" % (name, shown))
            continue
        ok = value >= limit if at_least else value <= limit
        print("%s: %s (%s %g)%s" % (name, shown, ">=" if at_least else "<=", limit,
                                    "" if ok else "  <- FAIL"))
        failed = failed or not ok
    if failed:
        for hint in a.hint:
            print("hint: " + hint)
    print("FAIL" if failed else "PASS")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
