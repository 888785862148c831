# Shared by the script tests that run the package's tools offline (no roscore): $here (this
# folder's parent, test/scripts), $root, $bin (RBPF_BIN: another build) and a work directory
# removed on exit (KEEP_WORK=1 keeps it for inspection).
#   source "$(dirname "$0")/lib/offline.sh"
#   require_tools simulate offline_slam      # FAIL and exit 1 unless each tool is built

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
root=$(cd "$here/../.." && pwd)
bin="${RBPF_BIN:-$root/build/devel/lib/rbpf_slam}"
work=$(mktemp -d)
trap '[ -n "${KEEP_WORK:-}" ] && echo "work directory kept: $work" || rm -rf "$work"' EXIT

require_tools() {
  local tool
  for tool in "$@"; do
    [ -x "$bin/$tool" ] || { echo "FAIL: $bin/$tool is not built"; exit 1; }
  done
}
