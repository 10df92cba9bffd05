#include <gtest/gtest.h>

#include "landmark_loop_closure/core/session_counter.h"

using namespace landmark_loop_closure;

// Sessions change where the odometry was re-initialised, a mark passing to the next keyframe when
// its own never came; paths grow within a session and carry over into the next; another map goes
// on from its own first session with no keyframe before.
TEST(SessionCounter, RestartsStartSessionsAndPathsGrowWithinOne) {
  SessionCounter sessions;
  sessions.markRestart(0);  // Before the map's first keyframe: its session is new already.
  sessions.enter(0);
  EXPECT_EQ(sessions.current(), 0u);
  EXPECT_DOUBLE_EQ(sessions.advance(planarPose(0, 0, 0)).metres, 0.0);
  sessions.enter(1);
  EXPECT_DOUBLE_EQ(sessions.advance(planarPose(3, 4, 0)).metres, 5.0);
  sessions.markRestart(2);  // Keyframe 2 never comes: keyframe 3 starts the new session.
  sessions.enter(3);
  EXPECT_EQ(sessions.current(), 1u);
  // The jump to the new odometry frame is no distance travelled.
  EXPECT_DOUBLE_EQ(sessions.advance(planarPose(100, 0, 0)).metres, 5.0);
  sessions.enter(4);
  EXPECT_EQ(sessions.current(), 1u);
  EXPECT_DOUBLE_EQ(sessions.advance(planarPose(101, 0, 0)).metres, 6.0);

  sessions.restartAt(7);
  sessions.markRestart(9);
  sessions.enter(9);
  EXPECT_EQ(sessions.current(), 7u);  // No keyframe yet on this map.
  EXPECT_DOUBLE_EQ(sessions.advance(planarPose(50, 0, 0)).metres, 0.0);

  EXPECT_FALSE(sessions.takePending());
  sessions.markPending();
  EXPECT_TRUE(sessions.takePending());
  EXPECT_FALSE(sessions.takePending());
}
