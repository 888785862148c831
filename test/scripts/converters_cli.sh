#!/usr/bin/env bash
# The log converters' command lines: -h / --help prints the usage and exits 0, a bad argument
# exits 2 (usage), an input that cannot be read exits 1 with a message naming it; none leaves
# a bag behind on failure.
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
bin="${RBPF_BIN:-$root/build/devel/lib/rbpf_slam}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
status=0

# expect NAME WANTED_STATUS PATTERN COMMAND...: runs COMMAND, checks its exit status and that
# its output (stdout and stderr) matches PATTERN.
expect() {
  local name=$1 wanted=$2 pattern=$3
  shift 3
  local got=0
  "$@" >"$work/out" 2>&1 || got=$?
  if [ "$got" -ne "$wanted" ]; then
    echo "FAIL: $name: exit status $got, expected $wanted"; sed 's/^/  /' "$work/out"; status=1
  elif ! grep -qE "$pattern" "$work/out"; then
    echo "FAIL: $name: output does not match '$pattern'"; sed 's/^/  /' "$work/out"; status=1
  else
    echo "ok: $name ($got)"
  fi
}

missing="$work/no_such_input"
expect "carmen_to_bag --help" 0 "usage: carmen_to_bag" "$bin/carmen_to_bag" --help
expect "carmen_to_bag bad option" 2 "usage: carmen_to_bag" "$bin/carmen_to_bag" a b --bogus
expect "carmen_to_bag missing log" 1 "no_such_input" "$bin/carmen_to_bag" "$missing.log" "$work/c.bag"
expect "mrclam_to_bag --help" 0 "usage: mrclam_to_bag" "$bin/mrclam_to_bag" -h
expect "mrclam_to_bag bad robot" 2 "usage: mrclam_to_bag" "$bin/mrclam_to_bag" "$work" x "$work/m.bag"
expect "mrclam_to_bag missing dataset" 1 "no_such_input" "$bin/mrclam_to_bag" "$missing" 1 "$work/m.bag"
expect "victoria_park_to_bag --help" 0 "usage: victoria_park_to_bag" "$bin/victoria_park_to_bag" --help
expect "victoria_park_to_bag bad option" 2 "usage: victoria_park_to_bag" \
  "$bin/victoria_park_to_bag" a b --dt
expect "victoria_park_to_bag missing input" 1 "no_such_input" \
  "$bin/victoria_park_to_bag" "$missing.txt" "$work/v.bag"
for bag in c.bag m.bag v.bag; do
  [ ! -e "$work/$bag" ] || { echo "FAIL: $bag written although the conversion failed"; status=1; }
done
[ "$status" -eq 0 ] && echo PASS
exit "$status"
