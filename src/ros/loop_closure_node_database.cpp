// The node's keyframe database: the file services and the stamps of loaded keyframes.
#include <chrono>
#include <cstdio>
#include <optional>
#include <string>

#include "landmark_loop_closure/common/text_and_files.h"
#include "loop_closure_node.h"
#include "messages/ros_conversions.h"

namespace landmark_loop_closure {

void LoopClosureNode::advertiseServices() {
  ros::NodeHandle services(private_node_);
  services.setCallbackQueue(&service_queue_);
  save_service_ =
      services.advertiseService("save_database", &LoopClosureNode::onSaveDatabase, this);
  load_service_ =
      services.advertiseService("load_database", &LoopClosureNode::onLoadDatabase, this);
  reset_service_ = services.advertiseService("reset", &LoopClosureNode::onResetDatabase, this);
  service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
  service_spinner_->start();
}

bool LoopClosureNode::onSaveDatabase(DatabaseFile::Request& request,
                                     DatabaseFile::Response& response) {
  const DetectorRuntime::SaveOutcome saved =
      runtime_->saveMap(expandPath(request.path), request.overwrite);
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
    MutexLock lock(stats_mutex_);
    database_status_ = saved.error;
  }
  return true;
}

void LoopClosureNode::noteDroppedAtMapSwitch(size_t dropped, const char* service,
                                             std::string* message) {
  if (dropped == 0) return;
  const std::string note = std::to_string(dropped) + " keyframe" + (dropped == 1 ? "" : "s") +
                           " queued before the " + service +
                           " dropped: taken against the previous map, they are not stored or "
                           "published";
  *message += "; " + note;
  ROS_WARN("%s", note.c_str());
}

bool LoopClosureNode::onLoadDatabase(DatabaseFile::Request& request,
                                     DatabaseFile::Response& response) {
  const auto load_start = std::chrono::steady_clock::now();
  const std::string path = expandPath(request.path);
  std::optional<MapReadSettings> settings;
  runtime_->withDetector([&](LoopDetector& detector) {
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
  const size_t dropped = runtime_->withDetector([&](LoopDetector& detector) {
    const std::string error = detector.map().adopt(std::move(*read));
    response.success = error.empty();
    response.keyframes = detector.database().size();
    if (!error.empty()) {
      response.message = error;
      ROS_ERROR("%s", error.c_str());
      return false;
    }
    keyframe_stamps_.clear();
    markers_.clear();
    const double load_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
    char seconds[32];
    std::snprintf(seconds, sizeof(seconds), "%.2f s", load_seconds);
    response.message = "loaded " + std::to_string(response.keyframes) + " keyframes from " + path +
                       " in " + seconds + "; session " + std::to_string(detector.session());
    ROS_INFO("%s", response.message.c_str());
    session_ = detector.session();
    noteMapSize(detector);
    MutexLock stats(stats_mutex_);
    database_status_ = path;
    return true;
  });
  noteDroppedAtMapSwitch(dropped, "load", &response.message);
  return true;
}

bool LoopClosureNode::onResetDatabase(ResetDatabase::Request&, ResetDatabase::Response& response) {
  const size_t dropped = runtime_->withDetector([&](LoopDetector& detector) {
    const size_t forgotten = detector.database().size();
    const MapSession::ResetOutcome outcome = detector.map().reset();
    runtime_->restartTimeline();  // New frames are not bounded by the old timeline's stamps.
    session_ = detector.session();
    noteMapSize(detector);
    keyframe_stamps_.clear();
    markers_.clear();
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

ros::Time LoopClosureNode::stampOf(uint64_t id) const {
  const auto known = keyframe_stamps_.find(id);
  if (known != keyframe_stamps_.end()) return known->second;
  // A loaded keyframe's from its record: the map keeps stamps to the nanosecond.
  if (const std::optional<int64_t> stamp_ns = detector_.map().keyframeStampNs(id);
      stamp_ns && *stamp_ns >= 0) {
    ros::Time stamp;
    stamp.fromNSec(static_cast<uint64_t>(*stamp_ns));
    return stamp;
  }
  const KeyframeSummary* summary = detector_.database().findSummary(id);
  return summary ? ros::Time(summary->stamp) : ros::Time();
}

void LoopClosureNode::publishAnnouncedKeyframes() {
  for (const AnnouncedKeyframe& keyframe : detector_.map().takeAnnounced()) {
    // Stored while ROS shuts down: roscpp drops what its connections have not sent yet, so it may
    // never reach a subscriber (ros::ok() stays true until the connections are gone). Counted,
    // and said at shutdown.
    if (!ros::ok() || ros::isShuttingDown()) ++keyframes_unpublished_at_shutdown_;
    const KeyframeSummary& summary = keyframe.summary;
    keyframe_publisher_.publish(toKeyframeMsg(summary.id, summary.session, keyframe.map_id,
                                              stampOf(summary.id), summary.pose,
                                              keyframes_frame_id_));
    if (fleet_) fleet_->onAnnounced(detector_, summary.id, keyframes_frame_id_);
  }
}

}  // namespace landmark_loop_closure
