#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test (gtest and rostest) with ctest, then the
# threaded core tests under ThreadSanitizer (scripts/tsan.sh).
# Exits non-zero when any test fails.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install_deps.sh
scripts/build.sh tests
export ROS_HOSTNAME=localhost ROS_MASTER_URI=http://localhost:11311
# ROS's Python tools need the system interpreter, not a pyenv/venv python3 first on PATH.
export PATH="/usr/bin:$PATH"
# The devel space puts this package on ROS_PACKAGE_PATH for rostest and roslaunch checks.
set +u
source _build/devel/setup.bash
set -u
cd _build
ctest --output-on-failure
catkin_test_results test_results
cd ..
# The threads of the core and runtime, under ThreadSanitizer.
scripts/tsan.sh
