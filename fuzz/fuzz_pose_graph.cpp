// libFuzzer target: the reference pose graph takes any sequence of keyframes, loops and
// optimisations (poses and covariances of any value: NaN, infinite, huge, singular, rotation
// blocks that are not rotations) without crashing, and every estimate it hands out stays finite.
// Run by scripts/fuzz.sh.
#include <cstdint>

#include "pose_graph_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (!landmark_loop_closure::fuzz::replayPoseGraphInput(data, size)) __builtin_trap();
  return 0;
}
