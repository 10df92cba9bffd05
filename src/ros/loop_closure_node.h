#pragma once

#include <memory>
#include <string>

#include <ros/ros.h>

#include "fleet_link.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/runtime/detector_runtime.h"
#include "map_services.h"
#include "node_counters.h"
#include "node_diagnostics.h"
#include "node_inputs.h"
#include "node_outputs.h"

namespace landmark_loop_closure {

/// Reads the node's options from its private namespace. Throws std::invalid_argument listing
/// every problem (type errors and validation); warns about keys it does not know.
NodeOptions loadNodeOptions(const ros::NodeHandle& private_node);

/// The ROS side of the detector, composed of parts with one job each: the inputs (images with
/// odometry or tf, camera_info, depth), the worker (DetectorRuntime), the outputs, the map
/// services, the diagnostics and, with other robots, the fleet link. This class only wires them
/// and says what happened at start and stop.
///
/// Threading: subscriber and timer callbacks run on the node handles' single-threaded queue and
/// only do cheap checks and keyframe selection; describing and searching run on the runtime's
/// worker thread, whose callbacks publish the results, so a callback never waits for it. The
/// services and the fleet link have threads of their own.
class LoopClosureNode {
 public:
  /// Throws std::runtime_error when the map at database_path cannot be opened.
  LoopClosureNode(ros::NodeHandle node, ros::NodeHandle private_node, const NodeOptions& options);
  ~LoopClosureNode();

  LoopClosureNode(const LoopClosureNode&) = delete;
  LoopClosureNode& operator=(const LoopClosureNode&) = delete;

 private:
  /// Opens database_path and says what it holds.
  void openMap();
  RuntimeListener runtimeListener();
  void startFleet();
  // DetectorRuntime's callbacks, on its worker thread with the detector locked.
  void onTimelineReset();
  void onKeyframeDone(const KeyframeJob& job, const KeyframeResult& result,
                      const PreparedKeyframe& prepared);
  /// The diagnostics timer: the map's check ends on its own thread, and the keyframes it held
  /// are published, without waiting for the next keyframe (only when the detector is free).
  void onDiagnosticsTimer();
  /// One ERROR for a map found damaged (MapSession::takeNewDamage()); nothing for "".
  static void reportMapDamage(const std::string& damage);

  ros::NodeHandle node_;
  ros::NodeHandle private_node_;
  NodeOptions options_;
  NodeCounters counters_;
  LoopDetector detector_;  ///< Reached through runtime_ once it runs.
  NodeDiagnostics diagnostics_;
  NodeInputs inputs_;
  ros::WallTimer diagnostics_timer_;
  std::unique_ptr<NodeOutputs> outputs_;  ///< Guarded by the runtime's lock: made after it.
  // Stopped in this order: the fleet link, the services, then the worker.
  std::unique_ptr<FleetLink> fleet_;  ///< Null without advanced/fleet/share and peers.
  std::unique_ptr<MapServices> services_;
  /// The worker, its queue and the detector lock; started before the parts that take the lock,
  /// destroyed first.
  std::unique_ptr<DetectorRuntime> runtime_;
};

}  // namespace landmark_loop_closure
