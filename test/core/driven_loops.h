#pragma once

// A true loop between two keyframes of a driven route, for the pose-graph tests.
#include <cstddef>

#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/sim/driven_laps.h"

namespace landmark_loop_closure {
namespace test_support {

/// The truth's relative pose between keyframes `query` and `match`, with 3 cm and 0.01 rad
/// standard deviations.
inline LoopConstraint trueLoop(const sim::DrivenLaps& drive, size_t query, size_t match) {
  LoopConstraint loop;
  loop.query_id = query;
  loop.match_id = match;
  loop.query_T_match = drive.truth[query].toIsometry().inverse() * drive.truth[match].toIsometry();
  loop.covariance.setZero();
  loop.covariance.diagonal() << 0.03 * 0.03, 0.03 * 0.03, 0.03 * 0.03, 0.01 * 0.01, 0.01 * 0.01,
      0.01 * 0.01;
  return loop;
}

}  // namespace test_support
}  // namespace landmark_loop_closure
