#!/usr/bin/env bash
# Builds the core library and the tests of its threads (the runtime's worker and services, the
# map's background check and stepped copy, the pose graph's worker) with ThreadSanitizer in
# _build_tsan/, and runs them.
# Fails on any report; test/tsan.supp lists the only ones ignored (lock order inside hnswlib and
# GDAL, libraries we do not build). scripts/test.sh runs it after the other tests (ctest entry
# tsan_threaded_tests, tier slow), and starts its build earlier, at the lowest priority, with
# --build-only while the other tiers run.
set -euo pipefail
cd "$(dirname "$0")/.."
build_only=false
case "${1:-}" in
  "") ;;
  --build-only) build_only=true ;;
  *) echo "usage: scripts/tsan.sh [--build-only]" >&2; exit 2 ;;
esac
TESTS=(test_detector_runtime test_keyframe_store test_loop_detector_map test_loop_detector_ids test_pose_graph_session test_pose_graph_runtime)
LOG=_build_tsan.log
echo "tsan: configuring and building ${TESTS[*]} (output in $LOG)"
# Build type None: only these flags (Debug would add full -g, a quarter of the build's time; -g1
# keeps the line numbers of a report). Asserts stay on (no NDEBUG).
flags="-fsanitize=thread -O1 -g1"
cmake -S . -B _build_tsan -DCMAKE_BUILD_TYPE=None -DCATKIN_ENABLE_TESTING=ON \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS=-fsanitize=thread \
  -DCMAKE_SHARED_LINKER_FLAGS=-fsanitize=thread > "$LOG" 2>&1 \
  || { tail -n 40 "$LOG"; echo "tsan: configuring failed" >&2; exit 1; }
cmake --build _build_tsan --target "${TESTS[@]}" -- -j"$(nproc)" >> "$LOG" 2>&1 \
  || { grep -E "error" "$LOG" | head -20; echo "tsan: build failed; see $LOG" >&2; exit 1; }
if $build_only; then
  exit 0
fi
export TSAN_OPTIONS="halt_on_error=1 exitcode=66 second_deadlock_stack=1 suppressions=$PWD/test/tsan.supp"
failed=0
for test in "${TESTS[@]}"; do
  if _build_tsan/devel/lib/landmark_loop_closure/"$test" > "_build_tsan/$test.log" 2>&1; then
    echo "tsan: $test clean ($(grep -o '[0-9]* tests* from [0-9]* test suites* ran' "_build_tsan/$test.log"))"
  else
    echo "tsan: $test FAILED; its report:" >&2
    grep -A40 -m1 "WARNING: ThreadSanitizer\|FAILED" "_build_tsan/$test.log" >&2 || tail -40 "_build_tsan/$test.log" >&2
    failed=1
  fi
done
exit "$failed"
