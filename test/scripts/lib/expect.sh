# expect NAME WANTED_STATUS PATTERN COMMAND...: runs COMMAND, checks its exit status and that its
# output (stdout and stderr) matches the extended regex PATTERN; prints ok / FAIL and sets
# status=1 on a failure. Needs $work (lib/offline.sh) and a `status` variable in the caller.
expect() {
  local name=$1 wanted=$2 pattern=$3
  shift 3
  local got=0
  "$@" >"$work/out" 2>&1 || got=$?
  if [ "$got" -ne "$wanted" ]; then
    echo "FAIL: $name: exit status $got, expected $wanted"; sed 's/^/  /' "$work/out"; status=1
  elif ! grep -qE -e "$pattern" "$work/out"; then
    echo "FAIL: $name: output does not match '$pattern'"; sed 's/^/  /' "$work/out"; status=1
  else
    echo "ok: $name ($got)"
  fi
}
