// The node's outputs, on the runtime's worker thread: keyframes, loops, candidates, markers and
// the match image.
#include "loop_closure_node.h"

#include <algorithm>
#include <sstream>

#include <cv_bridge/cv_bridge.h>
#include <visualization_msgs/MarkerArray.h>

#include "landmark_loop_closure/Keyframe.h"
#include "landmark_loop_closure/LoopCandidateArray.h"
#include "landmark_loop_closure/LoopClosure.h"
#include "landmark_loop_closure/core/match_image.h"
#include "landmark_loop_closure/descriptors/landmarks.h"
#include "landmark_loop_closure/geometry/metric_pose.h"
#include "messages/ros_conversions.h"

namespace landmark_loop_closure {

LoopClosureNode::NodeKeyframe LoopClosureNode::nodeKeyframe(const KeyframeJob& job) {
  const auto& source = std::any_cast<const FrameSource&>(job.source);
  return {source.image, job.id, source.image->header.stamp, job.pose, source.frame_id};
}

void LoopClosureNode::noteMapSize(const LoopDetector& detector) {
  map_keyframes_ = detector.database().size();
  MutexLock lock(stats_mutex_);
  database_bytes_ = detector.database().bytes();
  map_check_ = detector.map().check();
  map_damage_ = detector.map().damage();
  map_write_problem_ = detector.map().writeProblem();
  keyframes_not_written_ = detector.map().keyframesNotWritten();
}

void LoopClosureNode::reportMapDamage(const std::string& damage) {
  if (damage.empty()) return;
  ROS_ERROR(
      "%s: no loops are searched from now on and nothing more is written to the map (new "
      "keyframes are kept in memory only); ~reset keeps it aside and starts a new map, "
      "~load_database switches to a sound one",
      damage.c_str());
}

void LoopClosureNode::onTimelineReset() {
  noteMapSize(detector_);
  session_ = detector_.session();
  keyframe_stamps_.clear();
  markers_.clear();
}

void LoopClosureNode::onKeyframeDone(const KeyframeJob& job, const KeyframeResult& result,
                                     const PreparedKeyframe& prepared) {
  const NodeKeyframe keyframe = nodeKeyframe(job);
  const bool mapping = detector_.mode() == DetectorMode::kMapping;
  // Not stored and no store error: past the budget without a map file.
  const bool over_budget =
      result.written_not_searched || (!result.stored && result.store_error.empty());
  if (mapping && over_budget) {
    ++keyframes_over_budget_;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Database memory budget of %.0f MB reached (%zu keyframes searched): new "
                      "keyframes are searched for loops and %s",
                      options_.detector.database.memory_budget_mb, detector_.database().size(),
                      result.written_not_searched
                          ? "written to the map, not searched (raise the budget to search them)"
                          : "no longer stored (without a map file, database_path, all is in RAM)");
  }
  reportMapDamage(result.map_damage);
  keyframe_stamps_[job.id] = keyframe.stamp;
  // The keyframes carry the session (a camera gap keeps it, an odometry restart starts one).
  session_ = detector_.session();
  publishResults(keyframe, result, prepared.grey);
  if (!result.store_error.empty()) {
    ROS_ERROR_THROTTLE(kWarningPeriod, "Keyframe %lu %s: %s (%zu keyframes not stored so far)",
                       static_cast<unsigned long>(job.id),
                       result.stored         ? "is held back, but its id could not be reserved"
                       : result.loop_dropped ? "is neither stored nor published, nor its loop"
                                             : "is neither stored nor published",
                       result.store_error.c_str(), detector_.map().keyframesNotWritten());
  }
  noteMapSize(detector_);
}

std::string LoopClosureNode::expressRelativePose(AcceptedLoop* loop,
                                                 const std::string& camera_frame) const {
  if (options_.relative_pose_frame != RelativePoseFrame::kBase || !loop->relative_pose ||
      !loop->relative_pose->metric) {
    return camera_frame;
  }
  const std::optional<Pose>& mount = detector_.cameraMount();
  if (!mount) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Relative pose left in the camera frame %s: the camera mount is not known "
                      "yet (advanced/camera_mount/from_tf)",
                      camera_frame.c_str());
    return camera_frame;
  }
  const bool between_maps = loop->match_map_id != 0 && loop->match_map_id != loop->map_id;
  if (between_maps && !loop->match_camera_mount) {
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "Relative pose between robots left in the camera frame %s: the other robot "
                      "did not know its camera mount (its camera_mount, or tf)",
                      camera_frame.c_str());
    return camera_frame;
  }
  // Each end turned by its own robot's mount (the other robot's from its evidence).
  loop->relative_pose =
      inBodyFrames(*loop->relative_pose, *mount, between_maps ? *loop->match_camera_mount : *mount);
  return options_.base_frame;
}

void LoopClosureNode::publishResults(const NodeKeyframe& job, const KeyframeResult& result,
                                     const cv::Mat& grey) {
  keyframes_frame_id_ = job.frame_id;
  keyframes_camera_frame_ = job.image->header.frame_id;
  publishAnnouncedKeyframes();
  if (result.loop) {
    AcceptedLoop loop = *result.loop;
    const std::string pose_frame = expressRelativePose(&loop, job.image->header.frame_id);
    loop_publisher_.publish(
        toLoopMsg(loop, job.stamp, stampOf(loop.match_id), job.frame_id, pose_frame));
    ++loops_published_;
    const bool checked = result.loop->verification.has_value();
    const std::string how =
        checked ? "verified"
        : result.loop->appearance
            ? "verified by appearance, no relative pose: " + result.loop->appearance->describe()
        : !options_.detector.verification.enabled ? "unverified: verification off"
                                                  : "unverified: no usable camera_info";
    ROS_INFO("Loop: keyframe %lu matches keyframe %lu (score %.3f, %d consistent keyframes, %s)",
             static_cast<unsigned long>(result.loop->query_id),
             static_cast<unsigned long>(result.loop->match_id), result.loop->score,
             result.loop->consistent_keyframes, how.c_str());
  }
  if (candidates_publisher_.getNumSubscribers() > 0) {
    candidates_publisher_.publish(toCandidatesMsg(result, detector_.map().mapId(), job.stamp,
                                                  job.frame_id,
                                                  [this](uint64_t id) { return stampOf(id); }));
  }

  markers_.setFrameId(job.frame_id);
  markers_.addKeyframe(job.pose);
  // A loop into an earlier session joins two odometry frames: no line can be drawn in this one.
  if (result.loop && result.loop->match_session == result.loop->query_session) {
    markers_.addLoop(*result.loop);
  }
  for (const CandidateReport& candidate : result.candidates) {
    if (candidate.verdict != CandidateVerdict::kAwaitingConsistency &&
        candidate.verdict != CandidateVerdict::kOutscored &&
        candidate.verdict != CandidateVerdict::kOdometryRejected) {
      continue;
    }
    const KeyframeSummary* match = detector_.database().findSummary(candidate.match_id);
    if (match && match->session == detector_.session()) {
      markers_.addRejected(job.pose, match->pose);
    }
  }
  // Taken every keyframe (the change set restarts), sent when someone listens.
  const visualization_msgs::MarkerArray changed = markers_.changes(job.stamp);
  if (!changed.markers.empty() && markers_publisher_.getNumSubscribers() > 0) {
    markers_publisher_.publish(changed);
  }
  publishMatchImage(job, result, grey);
}

void LoopClosureNode::publishMatchImage(const NodeKeyframe& job, const KeyframeResult& result,
                                        const cv::Mat& grey) {
  // Once a loop has been shown it is held (the topic is latched) until the next one: candidates
  // only fill the view before the first loop.
  if (!result.loop && (loop_shown_ || match_image_publisher_.getNumSubscribers() == 0)) return;
  if (!result.loop && result.candidates.empty()) return;
  const CandidateReport& best = result.candidates.front();
  const uint64_t match_id = result.loop ? result.loop->match_id : best.match_id;
  MatchView view;
  std::ostringstream headline;
  std::ostringstream details;
  details.precision(3);
  details << std::fixed;
  if (result.loop) {
    const AcceptedLoop& loop = *result.loop;
    view.verdict = MatchView::Verdict::kAccepted;
    headline << "LOOP  keyframe " << loop.query_id << " -> " << loop.match_id;
    details << "score " << loop.score;
    if (loop.verification) {
      details << "   " << loop.verification->inliers << " inliers";
    } else if (loop.appearance) {
      details << "   " << loop.appearance->inliers << " cells agree";
    } else {
      details << "   unverified";
    }
    if (loop.metric_pose && loop.metric_pose->found) details << "   metric pose";
  } else {
    view.verdict = best.verdict == CandidateVerdict::kAwaitingConsistency
                       ? MatchView::Verdict::kCandidate
                       : MatchView::Verdict::kRejected;
    headline << (view.verdict == MatchView::Verdict::kCandidate ? "CANDIDATE" : "REJECTED")
             << "  keyframe " << result.keyframe_id << " -> " << best.match_id;
    details << "score " << best.score << "   " << toString(best.verdict);
    if (!best.detail.empty()) details << ": " << best.detail;
  }
  view.headline = headline.str();
  view.details = details.str();
  // The stored keyframes: their thumbnails share the landmark boxes' 160x120 frame.
  const std::shared_ptr<const KeyframeRecord> query =
      detector_.database().findRecord(result.keyframe_id);
  const std::shared_ptr<const KeyframeRecord> match = detector_.database().findRecord(match_id);
  view.query = query ? decodeThumbnail(query->thumbnail) : cv::Mat();
  view.match = match ? decodeThumbnail(match->thumbnail) : cv::Mat();
  if (query && match && !view.query.empty()) {
    std::vector<LandmarkMatch> pairs =
        matchLandmarks(query->descriptor.landmark_features, match->descriptor.landmark_features);
    std::sort(pairs.begin(), pairs.end(),
              [](const LandmarkMatch& a, const LandmarkMatch& b) { return a.cosine > b.cosine; });
    for (const LandmarkMatch& pair : pairs) {
      view.landmark_pairs.emplace_back(query->descriptor.landmark_boxes[pair.a],
                                       match->descriptor.landmark_boxes[pair.b]);
    }
    if (result.loop && result.loop->verification && query->local_features.image_size.width > 0) {
      const float scale =
          static_cast<float>(view.query.cols) / query->local_features.image_size.width;
      for (const auto& [q, m] : result.loop->verification->inlier_pairs) {
        view.inliers.emplace_back(q * scale, m * scale);
      }
    }
  }
  if (view.query.empty()) view.query = grey;
  std_msgs::Header header;
  header.stamp = job.stamp;
  match_image_publisher_.publish(
      cv_bridge::CvImage(header, "bgr8", renderMatchImage(view)).toImageMsg());
  loop_shown_ = loop_shown_ || result.loop.has_value();
}

}  // namespace landmark_loop_closure
