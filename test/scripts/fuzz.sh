#!/usr/bin/env bash
# Fuzzing: builds the libFuzzer targets of test/fuzz/ with clang (address and undefined
# behaviour sanitizers, the code under test compiled in) and runs each for FUZZ_SECONDS
# (default 60), one target per CPU at a time. Fails on any crash, sanitizer report or broken invariant; the input that
# found it is kept in build/fuzz/. Prints SKIP and exits 77 (scripts/test.sh: skipped) when
# clang's libFuzzer is missing.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
seconds="${FUZZ_SECONDS:-60}"
out="$root/build/fuzz"
mkdir -p "$out/obj"
if ! command -v clang++ >/dev/null; then
  echo "SKIP: clang++ not installed"
  exit 77
fi
echo 'extern "C" int LLVMFuzzerTestOneInput(const unsigned char*, unsigned long) { return 0; }' \
  >"$out/probe.cpp"
if ! clang++ -fsanitize=fuzzer "$out/probe.cpp" -o "$out/probe" 2>/dev/null; then
  echo "SKIP: clang++ has no libFuzzer runtime"
  exit 77
fi

export FUZZ_FLAGS="-std=c++17 -O1 -g -fsanitize=fuzzer-no-link,address,undefined \
-fno-sanitize-recover=undefined -I$root/include -I/usr/include/eigen3 -DNDEBUG"
export root out
# Every source compiled once (in parallel; again only when it or a header changed), then
# linked into each target.
compile() {
  local source=$1 object
  object="$out/obj/$(echo "${source#"$root"/}" | tr '/' '_').o"
  if [ ! -f "$object" ] || [ "$source" -nt "$object" ] ||
     [ -n "$(find "$root/include" "$root/test/fuzz" -newer "$object" -name '*.h' | head -1)" ]; then
    # shellcheck disable=SC2086
    clang++ $FUZZ_FLAGS -c "$source" -o "$object"
  fi
}
export -f compile
sources=$(find "$root/src/core" "$root/src/io" "$root/test/fuzz" -name '*.cpp' ! -name fuzz_conversions.cpp | sort)
echo "compiling $(echo "$sources" | wc -l) sources with clang (sanitizers on) ..."
echo "$sources" | xargs -P "$(nproc)" -I{} bash -c 'compile "$1"' _ {}
library=$(find "$out/obj" -name 'src_*.o' | sort)
# The ROS message conversions (fuzz_conversions): compiled apart, with the ROS headers and
# the package's generated messages, and linked into that target only.
ros_flags="-I$root/devel/include -I$root/build/devel/include"
# shellcheck disable=SC2086
clang++ $FUZZ_FLAGS $ros_flags -c "$root/src/ros/conversions.cpp" -o "$out/obj/ros_conversions.o"
# shellcheck disable=SC2086
clang++ $FUZZ_FLAGS $ros_flags -c "$root/test/fuzz/fuzz_conversions.cpp" \
  -o "$out/obj/test_fuzz_fuzz_conversions.cpp.o"
targets="fuzz_laser fuzz_sonar fuzz_config fuzz_landmarks fuzz_conversions"
for target in $targets; do
  extra=""
  [ "$target" = fuzz_conversions ] && extra="$out/obj/ros_conversions.o -lrostime -lcpp_common -lroscpp_serialization"
  # shellcheck disable=SC2086
  clang++ -fsanitize=fuzzer,address,undefined "$out/obj/test_fuzz_$target.cpp.o" $library \
    $extra -lyaml-cpp -lz -o "$out/$target"
done
# Each target fuzzes for $seconds on its own core, one per CPU at a time; the outcome is written
# to $out/$target.status (0: nothing found) and reported below in the targets' order.
fuzz() {
  local target=$1 seeds=()
  mkdir -p "$out/corpus_$target"
  [ -d "$root/test/fuzz/seeds_$target" ] && seeds=("$root/test/fuzz/seeds_$target")
  local result=0
  (cd "$out" && "./$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
      -artifact_prefix="$out/${target}_" "corpus_$target" "${seeds[@]+"${seeds[@]}"}" \
      >"$out/$target.log" 2>&1) || result=$?
  echo "$result" >"$out/$target.status"
}
export -f fuzz
export seconds
rm -f "$out"/*.status
echo $targets | tr ' ' '\n' | xargs -P "$(nproc)" -I{} bash -c 'fuzz "$1"' _ {}
status=0
for target in $targets; do
  if [ "$(cat "$out/$target.status" 2>/dev/null)" = 0 ]; then
    echo "ok $target: $(grep -E '^#[0-9]+' "$out/$target.log" | tail -1)"
  else
    echo "FAIL $target (log: $out/$target.log)"
    grep -E "ERROR|SUMMARY|runtime error|deadly|Test unit written" "$out/$target.log" | head -n 10
    status=1
  fi
done
[ "$status" -eq 0 ] && echo "PASS"
exit "$status"
