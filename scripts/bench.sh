#!/usr/bin/env bash
# Builds in Release, runs every Google Benchmark of benchmarks/ and the offline runner end to
# end (when ../shared/data has the recordings): laser on the real Intel and ACES bags, sonar on
# a 4 Hz ring emulated from the ACES log, range-bearing landmarks on MRCLAM dataset 6 robot 1
# (FastSLAM 2.0 and H-infinity), and writes the figures, the machine and the exact commands to
# docs/benchmarks.md. Timing only, never pass/fail.
#
#   ./scripts/bench.sh                      # about 4 minutes after the build, on 2 cores
#   BENCH_MIN_TIME=1 ./scripts/bench.sh     # steadier figures, slower
#   BENCH_SKIP_BUILD=1 BUILD_DIR=/tmp/b ./scripts/bench.sh   # use an existing build
#   BENCH_OFFLINE_ARGS="--set particles=30" ./scripts/bench.sh  # extra offline_slam arguments
#   BENCH_SEEDS="1" ./scripts/bench.sh      # filter seeds of the end-to-end runs (default 1 2 3)
#   BENCH_REPETITIONS=5 ./scripts/bench.sh  # runs per benchmark case, median reported (default 3)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

MIN_TIME=${BENCH_MIN_TIME:-0.5}  # seconds per benchmark case (google benchmark min_time)
REPETITIONS=${BENCH_REPETITIONS:-3}  # runs per case; the report gives their median
DATA=${BENCH_DATA:-$ROOT/../shared/data}
REPORT=${BENCH_REPORT:-$ROOT/docs/benchmarks.md}
BUILD=${BUILD_DIR:-$BUILD}
OUT=$BUILD/bench
read -r -a OFFLINE_ARGS <<<"${BENCH_OFFLINE_ARGS:-}"
read -r -a SEEDS <<<"${BENCH_SEEDS:-1 2 3}"

if [ -z "${BENCH_SKIP_BUILD:-}" ]; then
  install_missing
  build_package Release
fi
BIN=$BUILD/devel/lib/rbpf_slam
mkdir -p "$OUT"
rm -rf "$OUT"/*.json "$OUT"/offline_*

mapfile -t BENCHES < <(find "$BIN" "$BUILD" -maxdepth 1 -type f -executable -name 'bench_*' \
  2>/dev/null | sort -u)
if [ ${#BENCHES[@]} -eq 0 ]; then
  echo "bench.sh: no bench_* binary under $BIN or $BUILD (is libbenchmark-dev installed?)" >&2
  exit 1
fi

COMMANDS=()
START=$(date +%s)
for bench in "${BENCHES[@]}"; do
  name=$(basename "$bench")
  cmd=("$bench" "--benchmark_min_time=$MIN_TIME" "--benchmark_repetitions=$REPETITIONS"
       "--benchmark_report_aggregates_only=true" "--benchmark_out=$OUT/$name.json"
       "--benchmark_out_format=json")
  echo "== $name"
  "${cmd[@]}"
  COMMANDS+=("${cmd[*]}")
done

# End to end: offline_slam over whole recordings, one process per run (its summary.json
# gives the update times and the real-time factor). CASES lines: name|config|bag|reference.
CASES=()
for bag in intel aces; do
  if [ -f "$DATA/$bag.bag" ]; then
    CASES+=("$bag|laser_fastslam2|$DATA/$bag.bag|$DATA/$bag.ref.tum")
  else
    echo "bench.sh: $DATA/$bag.bag missing, skipping its laser run" >&2
  fi
done
# prepare NAME BAG "CONFIG..." COMMAND...: runs COMMAND (it writes BAG and BAG's .ref.tum) and
# adds one end-to-end case per config on that bag; a failed command is reported and skipped.
prepare() {
  local name=$1 bag=$2 configs=$3
  shift 3
  echo "== prepare $name: $*"
  if ! "$@" >"$OUT/$name.prepare.log" 2>&1; then
    echo "bench.sh: preparing $name failed (log: $OUT/$name.prepare.log)" >&2
    return 0
  fi
  COMMANDS+=("$*")
  local config
  for config in $configs; do CASES+=("$name|$config|$bag|${bag%.bag}.ref.tum"); done
}
# Sonar: the 4 Hz ring emulated from the ACES laser log (tools/emulate_sonar_ring.py, ~20 s).
if [ -f "$DATA/aces.bag" ]; then
  prepare aces_sonar4 "$OUT/aces_sonar4.bag" "sonar_fastslam2 sonar_robust" \
    /usr/bin/python3 "$ROOT/tools/emulate_sonar_ring.py" --bag "$DATA/aces.bag" \
    --reference "$DATA/aces.ref.tum" --output "$OUT/aces_sonar4.bag" --rate 4
fi
# Range-bearing landmarks: UTIAS MRCLAM dataset 6, robot 1, unknown association.
if [ -d "$DATA/mrclam6" ]; then
  prepare mrclam_robot1 "$OUT/mrclam_robot1.bag" "landmarks_fastslam2 landmarks_hinf" \
    "$BIN/mrclam_to_bag" "$DATA/mrclam6" 1 "$OUT/mrclam_robot1.bag"
fi

for entry in "${CASES[@]}"; do
  IFS='|' read -r name config bag reference <<<"$entry"
  for seed in "${SEEDS[@]}"; do
    cmd=("$BIN/offline_slam" --bag "$bag" --config "$ROOT/config/$config.yaml"
         --output "$OUT/offline_${name}__${config}__seed$seed" --seed "$seed"
         --reference "$reference" --no-progress "${OFFLINE_ARGS[@]}")
    echo "== offline_slam $name $config seed $seed"
    "${cmd[@]}" || echo "bench.sh: offline_slam on $name, $config (seed $seed) failed" >&2
    COMMANDS+=("${cmd[*]}")
  done
done
ELAPSED=$(( $(date +%s) - START ))

# The report: one table per benchmark binary, one for the end-to-end runs.
printf '%s\n' "${COMMANDS[@]}" >"$OUT/commands.txt"
INVOCATION=$(env | grep -E '^(BENCH_[A-Z_]+|BUILD_DIR)=' | sed -E 's/=(.*)/="\1"/' | tr '\n' ' ' || true)
export BENCH_INVOCATION="${INVOCATION}./scripts/bench.sh"
/usr/bin/python3 - "$OUT" "$REPORT" "$ROOT" "$ELAPSED" <<'EOF'
import datetime, json, os, pathlib, sys

out, report, root, elapsed = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]), sys.argv[3], sys.argv[4]
cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")),
           "unknown")
rel = lambda s: s.replace(root + "/", "").replace(os.path.dirname(root) + "/", "../")
lines = ["# Benchmarks", "",
         "Written by `./scripts/bench.sh` (timing only; not pass/fail tests).", "",
         "- date: " + datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
         "- nproc: %d" % os.cpu_count(), "- CPU: " + cpu,
         "- total run time of the benchmarks and end-to-end runs: %s s" % elapsed,
         "- load average when the report was written: " + open("/proc/loadavg").read().split()[0]
         + " (real time well above cpu time means other jobs were competing for the cores;"
         " compare figures of one run only)", ""]

def fmt(v):
    if float(v).is_integer() and abs(v) < 1e9:
        return str(int(v))
    return "%.3g" % v if abs(v) < 1000 else "%.4g" % v if abs(v) < 1e4 else "%.3e" % v

def medians(data):
    """The median of each case's repetitions (named as the case), or the single runs."""
    rows = [dict(b, name=b["run_name"]) for b in data["benchmarks"]
            if b.get("run_type") == "aggregate" and b.get("aggregate_name") == "median"]
    return rows or [b for b in data["benchmarks"] if b.get("run_type", "iteration") == "iteration"]

repetitions = os.environ.get("BENCH_REPETITIONS", "3")
lines += ["Benchmark figures are the median of %s repetitions of each case." % repetitions, ""]
for path in sorted(out.glob("bench_*.json")):
    data = json.load(open(path))
    lines += ["## " + path.stem, ""]
    benches = medians(data)
    skip = {"name", "run_name", "run_type", "repetitions", "repetition_index", "threads",
            "iterations", "real_time", "cpu_time", "time_unit", "family_index",
            "per_family_instance_index", "aggregate_name", "aggregate_unit", "error_occurred",
            "error_message"}
    counters = []
    for b in benches:
        counters += [k for k in b if k not in skip and k not in counters]
    aggregated = any(b.get("run_type") == "aggregate" for b in benches)
    lines.append("| case | time/iter (real) | cpu | %s | " % ("runs" if aggregated else "iterations")
                 + " | ".join(counters) + " |")
    lines.append("|---" * (4 + len(counters)) + "|")
    for b in benches:
        if b.get("error_occurred"):
            lines.append("| %s | error: %s |" % (b["name"], b.get("error_message", "")))
            continue
        unit = b["time_unit"]
        cells = [b["name"], "%s %s" % (fmt(b["real_time"]), unit), "%s %s" % (fmt(b["cpu_time"]), unit),
                 str(b["iterations"])]
        cells += [fmt(b[c]) if isinstance(b.get(c), (int, float)) else "" for c in counters]
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")

rows, factors, cpu_factors = [], {}, {}
for summary in sorted(out.glob("offline_*/summary.json")):
    s = json.load(open(summary))
    bag, config, seed_part = summary.parent.name[len("offline_"):].split("__")
    key = (bag, config)
    factor = s["bag_duration_s"] / max(s["wall_s"], 1e-9)
    factors.setdefault(key, []).append(factor)
    cpu = s.get("cpu_s")
    if cpu:
        cpu_factors.setdefault(key, []).append(s["bag_duration_s"] / max(cpu, 1e-9))
    rows.append("| %s | %s | %s | %.2f | %s | %.1f | %.0fx | %s | %d | %.2f | %.2f | %s | %d |" % (
        bag, config, s.get("seed", "?"), s["wall_s"], "%.2f" % cpu if cpu else "n/a",
        s["bag_duration_s"], factor,
        "%.0fx" % (s["bag_duration_s"] / cpu) if cpu else "n/a", s["updates"],
        s["update_ms_mean"], s["update_ms_p99"],
        "%.3f" % s["ate_rmse_m"] if "ate_rmse_m" in s else "n/a", s["landmarks"]))
if rows:
    lines += ["## offline_slam end to end", "",
              "intel, aces: the shared laser logs; aces_sonar4: the 4 Hz sonar ring emulated from "
              "the ACES log (`tools/emulate_sonar_ring.py`, docs/results.md \"Sonar at 4 Hz\"); "
              "mrclam_robot1: UTIAS MRCLAM dataset 6, robot 1, unknown association "
              "(`mrclam_to_bag`). ATE against each bag's reference (GMapping's for the logs, "
              "Vicon for MRCLAM). real-time factor = bag_duration_s / wall_s of one "
              "single-threaded process; cpu factor = bag_duration_s / cpu_s (the same with the "
              "time other jobs took from it removed).", "",
              "| bag | config | seed | wall_s | cpu_s | bag_duration_s | real-time factor | "
              "cpu factor | updates | update_ms_mean | update_ms_p99 | ATE [m] | landmarks |",
              "|---" * 13 + "|"] + rows + [""]

# The targets of issue 12, read off the figures above.
def case(name):
    for path in out.glob("bench_*.json"):
        for b in medians(json.load(open(path))):
            if (b["name"] == name or b["name"].startswith(name + "/")) and not b.get("error_occurred"):
                return b
    return None
checks = []
small, large = case("BM_FastSlam2UpdateVsLandmarks/100"), case("BM_FastSlam2UpdateVsLandmarks/10000")
if small and large:
    checks.append("- update cost, 100 particles, 10,000 vs 100 landmarks: %.2fx cpu time "
                  "(%.3g -> %.3g %s; target at most 3x)" % (
                      large["cpu_time"] / small["cpu_time"], small["cpu_time"], large["cpu_time"],
                      small["time_unit"]))
memory = case("BM_MapMemory/50000/100")
if memory:
    checks.append("- 100 particles x 50,000 landmarks after %d updates: peak resident set %.0f MB "
                  "(map %.1f MB, %.0f MB after the updates)" % (
                      memory["updates"], memory["peak_rss_MB"], memory["map_MB"],
                      memory["after_updates_MB"]))
extraction = [case("BM_LaserExtraction/%s/361" % m) for m in ("incremental", "split_and_merge")]
for b in extraction:
    if b:
        checks.append("- laser extraction, 361 beams, %s: %.3g %s per scan (target under 50 us)" % (
            b["name"].split("/")[1], b["real_time"], b["time_unit"]))
for (bag, config), f in sorted(factors.items()):
    f, c = sorted(f), sorted(cpu_factors.get((bag, config), []))
    checks.append("- %s, %s end to end: real-time factor median %.0fx over %d seeds (min %.0fx)%s%s" % (
        bag, config, f[len(f) // 2], len(f), f[0],
        "; by cpu time median %.0fx (min %.0fx)" % (c[len(c) // 2], c[0]) if c else "",
        "; target at least 300x" if bag == "intel" else ""))
if checks:
    lines += ["## Issue 12 targets", ""] + checks + [""]

lines += ["## Commands", "", "```", os.environ.get("BENCH_INVOCATION", "./scripts/bench.sh")]
lines += [rel(c) for c in (out / "commands.txt").read_text().splitlines()]
lines += ["```", ""]
report.parent.mkdir(parents=True, exist_ok=True)
report.write_text("\n".join(lines))
print("bench.sh: wrote " + str(report))
EOF
