# Shared by the script tests that run a landmark config on the shared UTIAS MRCLAM dataset 6
# (after lib/offline.sh and lib/shared_data.sh):
#   mrclam_run CONFIG [run_mrclam arguments]   # every robot, seeds 1-9, into $work, one run per
#                                              # CPU at a time; SKIP (exit 77) without the
#                                              # dataset, FAIL (exit 1) on error
#   /usr/bin/python3 "$here/lib/mrclam_check.py" "$work/results.json" --runs 45 --min-... N
mrclam_run() {
  local config=$1
  shift
  local data
  data="$(shared_data_dir)/mrclam6"
  if [ ! -d "$data" ]; then
    echo "SKIP: no shared data with mrclam6 (RBPF_SHARED_DATA, ../shared/data, /work/shared/data)"
    exit "$SKIP_STATUS"
  fi
  require_tools mrclam_to_bag offline_slam
  if ! /usr/bin/python3 "$root/benchmarks/run_mrclam" --data "$data" --bin-dir "$bin" \
      --configs "$config" --seeds 1,2,3,4,5,6,7,8,9 --jobs 0 --out "$work" "$@"; then
    echo "FAIL: run_mrclam failed; logs under $work (rerun with KEEP_WORK=1 to keep them)"
    exit 1
  fi
}
