// The node's diagnostics: input health, the map's state, counters and timings, read without ever
// waiting for the worker.
#pragma once

#include <cstdint>
#include <string>

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/runtime/detector_runtime.h"
#include "node_counters.h"
#include "node_inputs.h"

namespace landmark_loop_closure {

class FleetLink;

/// The diagnostics' summary while the map file refuses writes: "map file full: N keyframes not
/// stored (why)" for a full disk, "map file not written: ..." otherwise.
std::string mapWriteSummary(const std::string& problem, size_t keyframes_not_stored);

class NodeDiagnostics {
 public:
  NodeDiagnostics(ros::NodeHandle node, ros::NodeHandle private_node, const NodeOptions& options,
                  NodeCounters* counters);
  NodeDiagnostics(const NodeDiagnostics&) = delete;
  NodeDiagnostics& operator=(const NodeDiagnostics&) = delete;

  /// What the report reads besides its own state; each outlives the diagnostics' updates.
  void start(NodeInputs* inputs, const DetectorRuntime* runtime, FleetLink* fleet);
  /// Publishes the report now.
  void update() { updater_.force_update(); }

  /// The map's real size and bytes, check, damage and write problem, and the session: called
  /// wherever the database changes (start, keyframe, load, reset), with the detector held.
  void noteMap(const LoopDetector& detector) EXCLUDES(mutex_);
  /// The map's path, or why saving or opening it failed.
  void setMapStatus(const std::string& status) EXCLUDES(mutex_);

 private:
  /// The updater's callback: a read-only handler (it takes brief locks only, never the
  /// detector's; the Clang build checks that it calls nothing that does).
  void produce(diagnostic_updater::DiagnosticStatusWrapper& status) EXCLUDES(mutex_);

  const NodeOptions& options_;
  NodeCounters& counters_;
  NodeInputs* inputs_ = nullptr;
  const DetectorRuntime* runtime_ = nullptr;
  FleetLink* fleet_ = nullptr;
  diagnostic_updater::Updater updater_;
  uint64_t drops_seen_ = 0;       // produce() only: keyframes dropped at the last look,
  double last_drop_wall_ = -1e9;  // and when that count last grew.
  Mutex mutex_;  ///< The map's state: the worker and services write, produce() reads.
  size_t database_bytes_ GUARDED_BY(mutex_) = 0;
  std::string map_status_ GUARDED_BY(mutex_) = "memory only";
  std::string map_check_ GUARDED_BY(mutex_);          ///< MapSession::check().
  std::string map_damage_ GUARDED_BY(mutex_);         ///< MapSession::damage().
  std::string map_write_problem_ GUARDED_BY(mutex_);  ///< MapSession::writeProblem().
  size_t keyframes_not_written_ GUARDED_BY(mutex_) = 0;
};

}  // namespace landmark_loop_closure
