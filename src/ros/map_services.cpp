#include "map_services.h"

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>

#include "landmark_loop_closure/common/text_and_files.h"

namespace landmark_loop_closure {

MapServices::MapServices(ros::NodeHandle private_node, DetectorRuntime* runtime,
                         NodeOutputs* outputs, NodeDiagnostics* diagnostics)
    : runtime_(*runtime), outputs_(*outputs), diagnostics_(*diagnostics) {
  ros::NodeHandle services(private_node);
  services.setCallbackQueue(&queue_);
  save_service_ = services.advertiseService("save_database", &MapServices::onSave, this);
  load_service_ = services.advertiseService("load_database", &MapServices::onLoad, this);
  reset_service_ = services.advertiseService("reset", &MapServices::onReset, this);
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
}

void MapServices::stop() {
  if (spinner_) spinner_->stop();
}

bool MapServices::onSave(DatabaseFile::Request& request, DatabaseFile::Response& response) {
  const DetectorRuntime::SaveOutcome saved =
      runtime_.saveMap(expandPath(request.path), request.overwrite);
  response.success = saved.error.empty();
  response.keyframes = saved.keyframes;
  response.message =
      !saved.error.empty() ? saved.error
      : saved.own_map
          ? "all " + std::to_string(saved.keyframes) + " keyframes are committed to " + saved.target
          : "copied " + std::to_string(saved.keyframes) + " keyframes to " + saved.target +
                (saved.kept_as.empty() ? ""
                                       : "; the map that was there is kept as " + saved.kept_as);
  if (response.success) {
    ROS_INFO("%s", response.message.c_str());
  } else {
    ROS_ERROR("Could not save the map: %s", saved.error.c_str());
    diagnostics_.setMapStatus(saved.error);
  }
  return true;
}

void MapServices::noteDroppedAtMapSwitch(size_t dropped, const char* service,
                                         std::string* message) {
  if (dropped == 0) return;
  const std::string note = std::to_string(dropped) + " keyframe" + (dropped == 1 ? "" : "s") +
                           " queued before the " + service +
                           " dropped: taken against the previous map, they are not stored or "
                           "published";
  *message += "; " + note;
  ROS_WARN("%s", note.c_str());
}

bool MapServices::onLoad(DatabaseFile::Request& request, DatabaseFile::Response& response) {
  const auto load_start = std::chrono::steady_clock::now();
  const std::string path = expandPath(request.path);
  std::optional<MapReadSettings> settings;
  runtime_.withDetector([&](LoopDetector& detector) {
    response.keyframes = detector.database().size();
    if (path.empty()) {
      // The open map is loaded already; reloading it through a second connection would only fail.
      response.message =
          "no path given: name the map to load" +
          (detector.map().path().empty() ? std::string()
                                         : " (" + detector.map().path() + " is the map open now)");
    } else {
      settings = detector.map().readSettings();
    }
    return false;
  });
  // The map is opened and read beside the live one, which the worker goes on using meanwhile.
  std::optional<ReadMap> read;
  if (settings) {
    response.message = missingMapProblem(path);
    if (response.message.empty()) {
      try {
        read = readMap(path, *settings);
      } catch (const std::exception& error) {
        response.message = error.what();
      }
    }
  }
  if (!read) {
    response.success = false;
    ROS_ERROR("%s", response.message.c_str());
    return true;
  }
  // Swapped in briefly; keyframes queued against the previous map are dropped.
  const size_t dropped = runtime_.withDetector([&](LoopDetector& detector) {
    const std::string error = detector.map().adopt(std::move(*read));
    response.success = error.empty();
    response.keyframes = detector.database().size();
    if (!error.empty()) {
      response.message = error;
      ROS_ERROR("%s", error.c_str());
      return false;
    }
    outputs_.assertDetectorHeld();  // withDetector runs this with it held.
    outputs_.forgetMap();
    const double load_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
    char seconds[32];
    std::snprintf(seconds, sizeof(seconds), "%.2f s", load_seconds);
    response.message = "loaded " + std::to_string(response.keyframes) + " keyframes from " + path +
                       " in " + seconds + "; session " + std::to_string(detector.session());
    ROS_INFO("%s", response.message.c_str());
    diagnostics_.noteMap(detector);
    diagnostics_.setMapStatus(path);
    return true;
  });
  noteDroppedAtMapSwitch(dropped, "load", &response.message);
  return true;
}

bool MapServices::onReset(ResetDatabase::Request&, ResetDatabase::Response& response) {
  const size_t dropped = runtime_.withDetector([&](LoopDetector& detector) {
    const size_t forgotten = detector.database().size();
    const MapSession::ResetOutcome outcome = detector.map().reset();
    runtime_.restartTimeline();  // New frames are not bounded by the old timeline's stamps.
    diagnostics_.noteMap(detector);
    outputs_.assertDetectorHeld();  // withDetector runs this with it held.
    outputs_.forgetMap();
    response.success = outcome.problem.empty();
    response.message = "forgot " + std::to_string(forgotten) + " keyframes";
    if (!outcome.kept_as.empty()) {
      response.message += "; the earlier map is kept as " + outcome.kept_as;
    }
    if (!response.success) {
      response.message += ", but " + outcome.problem;
      ROS_ERROR("Reset: %s", response.message.c_str());
    } else {
      ROS_INFO("Reset: %s", response.message.c_str());
    }
    return true;
  });
  noteDroppedAtMapSwitch(dropped, "reset", &response.message);
  return true;
}

}  // namespace landmark_loop_closure
