#!/usr/bin/env bash
# One command from a fresh Debian 12 machine: installs what is missing, builds, generates the
# demo bag (a camera driven twice around a textured corridor, drifting odometry, ground truth)
# and plays it into the detector headless, printing each loop found as TRUE or FALSE.
#   scripts/demo.sh [--rviz] [--laps N] [--rate R]
set -euo pipefail
cd "$(dirname "$0")/.."
RVIZ=false
LAPS=2
RATE=2.0
while [ $# -gt 0 ]; do
  case "$1" in
    --rviz) RVIZ=true ;;
    --laps) LAPS="$2"; shift ;;
    --rate) RATE="$2"; shift ;;
    *) echo "usage: scripts/demo.sh [--rviz] [--laps N] [--rate R]" >&2; exit 2 ;;
  esac
  shift
done

scripts/install_deps.sh
if [ "$RVIZ" = true ] && ! command -v rviz > /dev/null; then
  sudo_cmd=""; [ "$(id -u)" -ne 0 ] && sudo_cmd=sudo
  $sudo_cmd apt-get install -y -qq --no-install-recommends rviz
fi
scripts/build.sh

source scripts/ros_env.sh
mkdir -p _demo
BAG=_demo/corridor_${LAPS}laps.bag
if [ ! -f "$BAG" ]; then
  _build/devel/lib/landmark_loop_closure/make_demo_bag "$BAG" "$LAPS"
fi
roslaunch --screen landmark_loop_closure demo.launch bag:="$(pwd)/$BAG" rviz:="$RVIZ" rate:="$RATE"
