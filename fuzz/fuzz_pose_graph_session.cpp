// libFuzzer target: the pose_graph node's bookkeeping (PoseGraphSession) takes anything the
// detector's topics could carry - keyframes of two maps with stamps going back and forth, ids
// repeated or skipped, loops of any map, run and frame, for keyframes that never come, in
// batches of any size - without crashing; every estimate stays finite and the session's list of
// loops matches the graph's. Run by scripts/fuzz.sh.
#include <cstdint>

#include "pose_graph_session_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (!landmark_loop_closure::fuzz::replayPoseGraphSessionInput(data, size)) __builtin_trap();
  return 0;
}
