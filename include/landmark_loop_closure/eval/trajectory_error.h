#pragma once

#include <vector>

#include "landmark_loop_closure/backend/pose_graph_session.h"
#include "landmark_loop_closure/eval/detector_evaluation.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {
namespace eval {

/// Position RMSE of an estimated trajectory against the true one (same length, pose by pose):
/// after moving the estimate so that its first pose lies on the truth's, and after the
/// similarity transform that fits it best, scale included (Umeyama; evo's -as). A drift in scale
/// shows as the difference between the two. All -1 for fewer than three poses.
struct TrajectoryError {
  double first_pose_rmse = -1.0;
  double similarity_rmse = -1.0;
  double scale = 1.0;  ///< Of that similarity transform.
};
TrajectoryError trajectoryError(const std::vector<Pose>& estimated, const std::vector<Pose>& truth);

/// Each pose's position error after the similarity transform that fits the whole trajectory
/// best (as trajectoryError's): the error of a part (one session) in the frame of the whole.
/// Empty for fewer than three poses.
std::vector<double> similarityAlignedErrors(const std::vector<Pose>& estimated,
                                            const std::vector<Pose>& truth);

/// The configured pass replayed into the reference pose graph as the pose_graph node receives it
/// (through the node's PoseGraphSession): keyframes in order with their sessions (each a chain),
/// each metric loop after its query keyframe, optimised on arrival.
struct PoseGraphReplay {
  std::vector<Pose> corrected;  ///< By keyframe id, like DetectorEvaluation::keyframe_poses.
  size_t metric_loops = 0;      ///< Loops given to the graph.
  size_t refused_loops = 0;     ///< Of those, refused, switched off or never confirmed.
  size_t refused_true_loops = 0;
  double heading_drift_per_m = 0.0;  ///< The graph's estimate (0 when it does not estimate one).
  size_t chains = 0;                 ///< One per session (odometry frame).
  size_t chains_joined = 0;          ///< Joined by accepted loops to the first (the first counted).
  size_t cross_session_loops = 0;    ///< Given to the graph between two sessions...
  size_t cross_session_loops_accepted = 0;  ///< ...and accepted.
};
PoseGraphReplay replayIntoPoseGraph(const DetectorEvaluation& evaluation,
                                    const PoseGraphOptions& options = {});

}  // namespace eval
}  // namespace landmark_loop_closure
