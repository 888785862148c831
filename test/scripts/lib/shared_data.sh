# The shared recordings (README.md there) for the tests that use real data beyond test/data:
# $RBPF_SHARED_DATA if set, else ../shared/data beside the repository, else /work/shared/data
# (where the development machines keep it; a clone elsewhere, as CI's, still finds it).
# Prints the directory, or nothing when none exists.
#   data=$(shared_data_dir)/mrclam6
shared_data_dir() {
  local root_dir
  root_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/../../.." && pwd)
  local candidate
  for candidate in "${RBPF_SHARED_DATA:-}" "$root_dir/../shared/data" /work/shared/data; do
    if [ -n "$candidate" ] && [ -d "$candidate" ]; then
      (cd "$candidate" && pwd)
      return 0
    fi
  done
}

# Script tests exit with this status when they cannot run here (missing data or compiler):
# scripts/test.sh reports them as skipped, not passed.
SKIP_STATUS=77
