// The pose graph saved beside the map (MAP-pose_graph): the keyframes and loops that entered it,
// in order, so that the next run's pose graph restores it by replaying them (and goes on with
// the chains the map's next sessions add). A checksummed file written atomically; a damaged one
// is reported and never written to.
#pragma once

#include <string>
#include <vector>

#include "landmark_loop_closure/backend/pose_graph_session.h"

namespace landmark_loop_closure {

/// Writes `inputs` (PoseGraphSession::kept()) to `path`: a temporary file renamed over it.
/// Returns "" or what failed.
std::string saveGraphFile(const std::string& path,
                          const std::vector<PoseGraphSession::Input>& inputs);

/// Reads a saved graph's inputs. Returns "" or why the file cannot be used (not a pose graph
/// file, damaged, of a newer version).
std::string readGraphFile(const std::string& path, std::vector<PoseGraphSession::Input>* inputs);

}  // namespace landmark_loop_closure
