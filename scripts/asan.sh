#!/usr/bin/env bash
# Builds the core and evaluation gtests with AddressSanitizer and UndefinedBehaviorSanitizer in
# _build_asan/ and runs them; fails on any report (memory errors, undefined behaviour, leaks).
# Well over an hour on two cores, so CI does not run it: run it after changing memory handling
# (decoders, image buffers, the database). hnswlib's own prefetch is left uninstrumented (see
# LLC_HNSWLIB_UNINSTRUMENTED in CMakeLists.txt).
#   scripts/asan.sh [test_name ...]   (default: every core and evaluation gtest)
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "$#" -gt 0 ]; then
  TESTS=("$@")
else
  mapfile -t TESTS < <(grep -o 'test_[a-z0-9_]*' cmake/tests.cmake |
    sort -u | while read -r name; do [ -f "test/core/$name.cpp" ] && echo "$name"; done)
fi
LOG=_build_asan.log
echo "asan: configuring and building ${#TESTS[@]} tests (output in $LOG)"
flags="-fsanitize=address,undefined -fno-omit-frame-pointer -O1 -g"
cmake -S . -B _build_asan -DCMAKE_BUILD_TYPE=Debug -DCATKIN_ENABLE_TESTING=ON \
  -DLLC_HNSWLIB_UNINSTRUMENTED=ON -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" > "$LOG" 2>&1 \
  || { tail -n 40 "$LOG"; echo "asan: configuring failed" >&2; exit 1; }
cmake --build _build_asan --target "${TESTS[@]}" -- -j"$(nproc)" >> "$LOG" 2>&1 \
  || { grep -E "error" "$LOG" | head -20; echo "asan: build failed; see $LOG" >&2; exit 1; }
export ASAN_OPTIONS="detect_leaks=1"
export UBSAN_OPTIONS="print_stacktrace=1 halt_on_error=1"
failed=0
for test in "${TESTS[@]}"; do
  if _build_asan/devel/lib/landmark_loop_closure/"$test" > "_build_asan/$test.log" 2>&1; then
    echo "asan: $test clean"
  else
    echo "asan: $test FAILED; its report:" >&2
    grep -A30 -m1 "runtime error\|ERROR: \(Address\|Leak\)Sanitizer\|FAILED" \
      "_build_asan/$test.log" >&2 || tail -40 "_build_asan/$test.log" >&2
    failed=1
  fi
done
exit "$failed"
