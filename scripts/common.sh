#!/usr/bin/env bash
# Shared set-up for scripts/*.sh: installs what is missing (Debian's ROS 1 packages), puts the
# system python first (a pyenv python3 lacks catkin_pkg) and configures + builds into build/.
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
BUILD="$ROOT/build"
# The devel space sits beside build/ and build/devel links to it: rosrun skips every file under
# PACKAGE/build/, so executables in build/devel/lib would be invisible to `rosrun rbpf_slam X`.
DEVEL="$ROOT/devel"
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH

APT_PACKAGES=(ros-base-dev libtf2-ros-dev libtf2-geometry-msgs-dev libsensor-msgs-dev
  libnav-msgs-dev libvisualization-msgs-dev libdiagnostic-msgs-dev libstd-srvs-dev librosbag-dev
  libtopic-tools-dev librostest-dev python3-rostest ros-message-generation libeigen3-dev
  libgtest-dev libtf2-msgs-dev
  python3-roslaunch python3-rosmaster rosbash python3-rostopic python3-rosbag python3-sensor-msgs
  libyaml-cpp-dev
  # tf2-tools: pioneer_laser.launch's static_transform_publisher; the python messages let
  # rostopic echo /tf, /diagnostics, ~trajectory, ~landmarks, ~map and rosservice call ~pause,
  # ~dynamic_map (README)
  tf2-tools python3-tf2-msgs python3-diagnostic-msgs python3-std-srvs python3-nav-msgs
  python3-visualization-msgs
  libbenchmark-dev zlib1g-dev cmake g++ make python3-numpy python3-yaml python3-matplotlib rviz
  xvfb imagemagick)

install_missing() {
  local missing=()
  for p in "${APT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "Installing: ${missing[*]}"
    local sudo=""
    [ "$(id -u)" -ne 0 ] && sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
  fi
}

build_package() {
  local build_type=${1:-Release}
  mkdir -p "$BUILD" "$DEVEL"
  # A build/devel directory from an older layout is replaced by the link.
  if [ -d "$BUILD/devel" ] && [ ! -L "$BUILD/devel" ]; then rm -rf "$BUILD/devel"; fi
  ln -sfn ../devel "$BUILD/devel"
  echo "Building ($build_type) in $BUILD ..."
  # ccache, when the machine has it (developers' worktrees share one cache; CI has none).
  local launcher=()
  if command -v ccache >/dev/null 2>&1; then
    export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$(dirname "$ROOT")}"
    launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  fi
  cmake -S "$ROOT" -B "$BUILD" -DCMAKE_BUILD_TYPE="$build_type" "${launcher[@]}" \
    -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCATKIN_DEVEL_PREFIX="$DEVEL" >"$BUILD/cmake.log" 2>&1 \
    || { tail -n 40 "$BUILD/cmake.log"; echo "cmake failed (log: $BUILD/cmake.log)" >&2; return 1; }
  make -C "$BUILD" -j"$(nproc)" >"$BUILD/make.log" 2>&1 \
    || { grep -E "error|Error" "$BUILD/make.log" | head -n 40; echo "build failed (log: $BUILD/make.log)" >&2; return 1; }
}

ros_env() {
  set +u
  # shellcheck disable=SC1091
  source "$BUILD/devel/setup.bash"
  set -u
  export ROS_PACKAGE_PATH="$ROOT:${ROS_PACKAGE_PATH:-}"
  export ROS_HOME="${ROS_HOME:-$BUILD/ros_home}"
  export ROS_LOG_DIR="$ROS_HOME/log"
  mkdir -p "$ROS_LOG_DIR"
}
