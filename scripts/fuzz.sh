#!/usr/bin/env bash
# Fuzzes the database loader, the image/depth conversion, the pose graph, the pose_graph node's
# bookkeeping and the detector's worker path (admit, addKeyframe) for a bounded time each:
#   scripts/fuzz.sh [seconds per target, default 60]
# Builds the libFuzzer targets with clang, AddressSanitizer and UndefinedBehaviorSanitizer in
# _fuzz/, starts each from its seeds in fuzz/seeds/<target>/ (kept regression inputs included),
# and fails when a target crashes; the crashing input is left in _fuzz/crashes/. Fix the bug, then
# copy the input into fuzz/seeds/<target>/ so tests and later runs replay it.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
scripts/install_deps.sh
if ! command -v clang++ > /dev/null; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get install -y -qq --no-install-recommends clang
fi
cmake -S . -B _fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCATKIN_ENABLE_TESTING=OFF \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DLLC_FUZZERS=ON \
  -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined,fuzzer-no-link -fno-omit-frame-pointer" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" > _fuzz.log 2>&1 \
  || { cat _fuzz.log; exit 1; }
TARGETS=(fuzz_old_map_file fuzz_image_message fuzz_pose_graph fuzz_pose_graph_session
  fuzz_loop_detector)
cmake --build _fuzz --target "${TARGETS[@]}" -- -j"$(nproc)" >> _fuzz.log 2>&1 \
  || { tail -50 _fuzz.log; exit 1; }
mkdir -p _fuzz/crashes
for target in "${TARGETS[@]}"; do
  corpus="_fuzz/corpus/$target"
  mkdir -p "$corpus"
  echo "fuzz: $target for ${seconds} s"
  UBSAN_OPTIONS=halt_on_error=1 "_fuzz/devel/lib/landmark_loop_closure/$target" \
    -max_total_time="$seconds" -rss_limit_mb=2048 -print_final_stats=1 \
    -artifact_prefix="_fuzz/crashes/$target-" "$corpus" "fuzz/seeds/$target" 2>&1 \
    | grep -E "^(#[0-9]+ +DONE|stat::number_of_executed_units|stat::peak_rss|==[0-9]+==ERROR|SUMMARY)" \
    || true
  if ls "_fuzz/crashes/$target-"* > /dev/null 2>&1; then
    echo "fuzz: $target crashed; inputs in _fuzz/crashes/"
    exit 1
  fi
done
echo "fuzz: no crash"
