// libFuzzer target: the detector's worker path (admit, then addKeyframe: describe, search, the
// decision, geometric and appearance checks, depths, triangulation, storing) takes any image
// type and size, depth image, pose, stamp and intrinsics a camera driver or odometry could send,
// with mode switches, odometry restarts and resets between them, without crashing or throwing;
// every loop names a stored keyframe before it and carries finite numbers. Run by scripts/fuzz.sh.
#include <cstdint>

#include "loop_detector_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (!landmark_loop_closure::fuzz::replayLoopDetectorInput(data, size)) __builtin_trap();
  return 0;
}
