#!/usr/bin/env bash
# The README's test command and CI's.
#   scripts/test.sh          installs what is missing, builds, and runs every tier: unit, node,
#                            tool and data side by side (ctest -j, one job per core), then slow
#                            (ThreadSanitizer, scripts/tsan.sh; Clang's thread-safety analysis,
#                            scripts/thread_safety.sh); cmake/test_tiers.cmake says
#                            which entry is in which tier
#   scripts/test.sh --quick  the unit tier (every gtest of the libraries) on the build already in
#                            _build/, rebuilding what changed; no apt, no ROS master
# Exits non-zero when any test fails, and, where ../shared/data is here (CI), when any test or
# test case was skipped: a missing dataset or model is not a pass.
set -euo pipefail
cd "$(dirname "$0")/.."
quick=false
case "${1:-}" in
  "") ;;
  --quick) quick=true ;;
  *) echo "usage: scripts/test.sh [--quick]" >&2; exit 2 ;;
esac
jobs="$(nproc)"
# ROS's Python tools need the system interpreter, not a pyenv/venv python3 first on PATH.
export PATH="/usr/bin:$PATH"
export ROS_HOSTNAME=localhost ROS_MASTER_URI=http://localhost:11311

if $quick; then
  if [ ! -f _build/CMakeCache.txt ]; then
    echo "test: no build in _build/ yet: run scripts/test.sh (or scripts/build.sh tests) once" >&2
    exit 1
  fi
  echo "test: building the unit tier's tests (what changed)"
  cmake --build _build --target unit_tests -- -j"$jobs" > _build_quick.log 2>&1 ||
    { grep -E "error|Error" _build_quick.log | head -20; echo "test: build failed; see _build_quick.log" >&2
      exit 1; }
  cd _build
  ctest -L unit -j"$jobs" --output-on-failure
  exit 0
fi

scripts/install_deps.sh
scripts/build.sh tests
# The devel space puts this package on ROS_PACKAGE_PATH for rostest and roslaunch checks.
set +u
source _build/devel/setup.bash
set -u
# ThreadSanitizer's build starts now at the lowest priority: the other tiers leave processor time
# idle (rostests play laps in real time) and the build takes only that. Its errors, if any, are
# reported by the slow tier's own run of scripts/tsan.sh, which then finds the build done.
nice -n 19 scripts/tsan.sh --build-only > /dev/null 2>&1 &
tsan_build=$!
# Clang's thread-safety build the same way, after it (the two would share the same idle time).
(wait_for_tsan() { while kill -0 "$tsan_build" 2> /dev/null; do sleep 5; done; }
 wait_for_tsan; nice -n 19 scripts/thread_safety.sh --build-only > /dev/null 2>&1) &
clang_build=$!
cd _build
status=0
# Every tier but slow side by side, then ThreadSanitizer.
ctest -j"$jobs" -LE slow --output-on-failure 2>&1 | tee ctest.log || status=1
wait "$tsan_build" || true
wait "$clang_build" || true
ctest -L slow --output-on-failure 2>&1 | tee -a ctest.log || status=1
catkin_test_results test_results | tee catkin_test_results.log || status=1
if [ -d ../../shared/data ]; then
  # ctest lists entries that did not run ("Not Run", "Skipped", "Disabled"); catkin_test_results
  # counts gtest cases that called GTEST_SKIP inside an entry that passed.
  if grep -q "tests did not run" ctest.log; then
    echo "test: ../shared/data is here, yet entries were skipped (listed above)" >&2
    status=1
  fi
  skipped_cases="$(sed -nE 's/^Summary: .* ([0-9]+) skipped.*/\1/p' catkin_test_results.log)"
  if [ "${skipped_cases:-0}" != 0 ]; then
    echo "test: ../shared/data is here, yet $skipped_cases test cases were skipped:" >&2
    grep -l "<skipped" test_results/*/*.xml >&2 || true
    status=1
  fi
fi
exit "$status"
