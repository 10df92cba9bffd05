#!/usr/bin/env bash
# Builds the libraries and the nodes with Clang's thread-safety analysis in _build_clang/
# (-Wthread-safety, its warnings errors): every member a mutex guards says so (GUARDED_BY,
# include/landmark_loop_closure/common/thread_annotations.h), and a read or write without that
# mutex, or a function called without the lock it REQUIRES, does not compile.
#   scripts/thread_safety.sh               build, and fail on any thread-safety warning
#   scripts/thread_safety.sh --build-only  the same, quiet (scripts/test.sh starts it early)
# scripts/test.sh runs it after the other tests (ctest entry thread_safety_build, tier slow);
# test/thread_safety/ holds the check that the analysis does refuse a violation (ctest entry
# thread_safety_refuses_violations, tier unit).
set -euo pipefail
cd "$(dirname "$0")/.."
build_only=false
case "${1:-}" in
  "") ;;
  --build-only) build_only=true ;;
  *) echo "usage: scripts/thread_safety.sh [--build-only]" >&2; exit 2 ;;
esac
if ! command -v clang++ > /dev/null; then
  echo "thread_safety: clang++ is missing: scripts/install_deps.sh installs it (Debian's clang)" >&2
  exit 1
fi
TARGETS=(landmark_loop_closure_core landmark_loop_closure_backend landmark_loop_closure_config
  landmark_loop_closure_eval landmark_loop_closure_messages landmark_loop_closure_bag
  landmark_loop_closure_ros_parameters landmark_loop_closure_nodelet
  landmark_loop_closure_pose_graph_nodelet)
LOG=_build_clang.log
$build_only || echo "thread_safety: building ${#TARGETS[@]} libraries with clang (output in $LOG)"
# No optimisation, no debug information: only the analysis is wanted.
cmake -S . -B _build_clang -DCMAKE_BUILD_TYPE=None -DCATKIN_ENABLE_TESTING=OFF \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_CXX_FLAGS="-O0 -Wthread-safety -Werror=thread-safety" > "$LOG" 2>&1 \
  || { tail -n 40 "$LOG"; echo "thread_safety: configuring failed" >&2; exit 1; }
status=0
cmake --build _build_clang --target "${TARGETS[@]}" -- -j"$(nproc)" >> "$LOG" 2>&1 || status=1
# Clang tags each as [-Wthread-safety-...] or, made an error, [-Werror,-Wthread-safety-...].
warnings="$(grep -c "Wthread-safety" "$LOG" || true)"
if [ "$status" != 0 ] || [ "$warnings" != 0 ]; then
  grep -E "error|Wthread-safety" "$LOG" | head -40 >&2
  echo "thread_safety: $warnings thread-safety errors or the build failed; its output is in $LOG" >&2
  exit 1
fi
$build_only || echo "thread_safety: ${#TARGETS[@]} libraries, 0 thread-safety warnings"
