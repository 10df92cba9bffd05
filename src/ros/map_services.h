// The map's services: ~save_database, ~load_database and ~reset, on their own thread. Each
// reaches the detector through DetectorRuntime::withDetector, so it waits for the keyframe in
// hand and never blocks the image callbacks; a load reads the new map beside the live one.
#pragma once

#include <memory>
#include <string>

#include <ros/callback_queue.h>
#include <ros/ros.h>

#include "landmark_loop_closure/DatabaseFile.h"
#include "landmark_loop_closure/ResetDatabase.h"
#include "landmark_loop_closure/runtime/detector_runtime.h"
#include "node_diagnostics.h"
#include "node_outputs.h"

namespace landmark_loop_closure {

class MapServices {
 public:
  /// Advertises and starts the services' thread; `runtime`, `outputs` and `diagnostics` outlive
  /// the services (stop()).
  MapServices(ros::NodeHandle private_node, DetectorRuntime* runtime, NodeOutputs* outputs,
              NodeDiagnostics* diagnostics);
  ~MapServices() { stop(); }
  MapServices(const MapServices&) = delete;
  MapServices& operator=(const MapServices&) = delete;

  /// Ends the services' thread (before the worker stops). Idempotent.
  void stop();

 private:
  bool onSave(DatabaseFile::Request& request, DatabaseFile::Response& response);
  bool onLoad(DatabaseFile::Request& request, DatabaseFile::Response& response);
  bool onReset(ResetDatabase::Request& request, ResetDatabase::Response& response);
  /// Says (log and service `message`) how many keyframes queued before a load or reset the
  /// worker drops.
  static void noteDroppedAtMapSwitch(size_t dropped, const char* service, std::string* message);

  DetectorRuntime& runtime_;
  NodeOutputs& outputs_;
  NodeDiagnostics& diagnostics_;
  ros::CallbackQueue queue_;
  ros::ServiceServer save_service_;
  ros::ServiceServer load_service_;
  ros::ServiceServer reset_service_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
};

}  // namespace landmark_loop_closure
