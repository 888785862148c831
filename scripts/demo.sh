#!/usr/bin/env bash
# Installs what is missing, builds in Release, runs laser FastSLAM 2.0 on the bundled Intel lab
# slice, prints accuracy against the reference, runtime and landmark count, and where it wrote.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

BAG=${1:-$ROOT/test/data/intel_head.bag}
REF=${2:-${BAG%.bag}.ref.tum}
CONFIG=${CONFIG:-$ROOT/config/laser_fastslam2.yaml}
OUT=${OUT:-$ROOT/out/demo}

install_missing
mkdir -p "$BUILD"
build_package Release
ros_env
mkdir -p "$OUT"
BIN="$BUILD/devel/lib/rbpf_slam"
"$BIN/offline_slam" --bag "$BAG" --config "$CONFIG" --output "$OUT" --reference "$REF"
echo
echo "== evaluation against $(basename "$REF") =="
"$BIN/evaluate" "$OUT/trajectory.tum" "$REF"
echo
echo "trajectory: $OUT/trajectory.tum"
echo "landmarks:  $OUT/landmarks.yaml"
echo "summary:    $OUT/summary.json"
echo "map:        $OUT/map.png"
