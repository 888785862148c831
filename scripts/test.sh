#!/usr/bin/env bash
# Installs what is missing, builds, runs every unit test (gtest via ctest, no roscore) and every
# integration test (rostest), prints the totals and exits non-zero on any failure.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

install_missing
mkdir -p "$BUILD"
build_package Release
ros_env

passed=0 failed=0 skipped=0 failures=() skips=()
echo "== unit tests (ctest) =="
if (cd "$BUILD" && ctest --output-on-failure -j"$(nproc)" 2>&1 | tee "$BUILD/ctest.log" | tail -n 25); then :; fi
unit_total=$(grep -oE "tests passed, [0-9]+ tests failed out of [0-9]+" "$BUILD/ctest.log" | grep -oE "[0-9]+$" || echo 0)
unit_failed=$(grep -oE "[0-9]+ tests failed out of" "$BUILD/ctest.log" | grep -oE "^[0-9]+" || echo 0)
[ -z "$unit_total" ] && unit_total=0
passed=$((passed + unit_total - unit_failed))
failed=$((failed + unit_failed))
[ "$unit_failed" -gt 0 ] && failures+=("unit tests: $unit_failed failed (see $BUILD/ctest.log)")
[ "$unit_total" -eq 0 ] && { failures+=("no unit test ran"); failed=$((failed + 1)); }

echo "== integration tests (rostest) =="
for t in "$ROOT"/test/rostest/*.test; do
  [ -e "$t" ] || continue
  name=$(basename "$t")
  # Without --text: with it rostest exits 0 even when a test case fails.
  if rostest rbpf_slam "$name" >"$BUILD/rostest_${name%.test}.log" 2>&1; then
    echo "PASS $name"
    passed=$((passed + 1))
  else
    echo "FAIL $name (log: $BUILD/rostest_${name%.test}.log, test output: $ROS_LOG_DIR)"
    tail -n 30 "$BUILD/rostest_${name%.test}.log"
    grep -h -A4 "<failure" "$ROS_HOME"/test_results/rbpf_slam/rosunit-*.xml 2>/dev/null | head -n 40 || true
    failed=$((failed + 1))
    failures+=("rostest $name")
  fi
done

for s in "$ROOT"/test/scripts/*.sh; do
  [ -e "$s" ] || continue
  name=$(basename "$s")
  result=0
  bash "$s" >"$BUILD/script_${name%.sh}.log" 2>&1 || result=$?
  if [ "$result" -eq 0 ]; then
    echo "PASS $name"
    passed=$((passed + 1))
  elif [ "$result" -eq 77 ]; then  # the test cannot run here (test/scripts/lib/shared_data.sh)
    echo "SKIP $name: $(grep -m1 '^SKIP' "$BUILD/script_${name%.sh}.log" || true)"
    skipped=$((skipped + 1))
    skips+=("$name")
  else
    echo "FAIL $name (log: $BUILD/script_${name%.sh}.log)"
    tail -n 20 "$BUILD/script_${name%.sh}.log"
    failed=$((failed + 1))
    failures+=("script $name")
  fi
done

echo
for f in "${failures[@]+"${failures[@]}"}"; do echo "failed: $f"; done
for f in "${skips[@]+"${skips[@]}"}"; do echo "skipped: $f"; done
echo "$passed passed, $failed failed, $skipped skipped"
[ "$failed" -eq 0 ]
