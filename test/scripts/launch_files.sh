#!/usr/bin/env bash
# Every launch file parses with its default arguments (roslaunch --nodes resolves the args,
# the includes and $(find ...)), plus the values of a "test-args:" line in it for arguments it
# requires, and every node it starts from this package exists as an executable that roslaunch
# can find.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
status=0
for launch in "$root"/launch/*.launch; do
  name=$(basename "$launch")
  read -r -a args <<<"$(sed -n 's/.*test-args:\(.*\)$/\1/p' "$launch" | sed 's/-->//')"
  if ! nodes=$(roslaunch --nodes "$launch" "${args[@]}" 2>&1); then
    echo "FAIL: $name does not parse:"; echo "$nodes"; status=1; continue
  fi
  for type in $(grep -oE 'pkg="rbpf_slam" type="[^"]+"' "$launch" | sed -E 's/.*type="([^"]+)"/\1/'); do
    if ! python3 -c "import sys, roslib.packages as p; sys.exit(0 if p.find_node('rbpf_slam', '$type') else 1)"; then
      echo "FAIL: $name starts rbpf_slam/$type, which roslaunch cannot find"; status=1
    fi
  done
  # A node of this package reads its private parameters strictly, so one left on the master by
  # an earlier launch (another config's keys) must not reach it: every tag clears them.
  if grep -E '<node [^>]*pkg="rbpf_slam"' "$launch" | grep -vq 'clear_params="true"'; then
    echo "FAIL: $name starts an rbpf_slam node without clear_params=\"true\""; status=1
  fi
  echo "ok $name: $(echo "$nodes" | tr '\n' ' ')"
done
[ "$status" -eq 0 ] && echo "PASS"
exit "$status"
