#include "node_outputs.h"

#include <algorithm>
#include <sstream>

#include <cv_bridge/cv_bridge.h>
#include <visualization_msgs/MarkerArray.h>

#include "fleet_link.h"
#include "landmark_loop_closure/Keyframe.h"
#include "landmark_loop_closure/LoopCandidateArray.h"
#include "landmark_loop_closure/core/match_image.h"
#include "landmark_loop_closure/descriptors/landmarks.h"
#include "landmark_loop_closure/geometry/metric_pose.h"
#include "messages/ros_conversions.h"

namespace landmark_loop_closure {

NodeOutputs::NodeOutputs(ros::NodeHandle node, ros::NodeHandle private_node,
                         const NodeOptions& options, NodeCounters* counters,
                         const Mutex& detector_mutex)
    : options_(options),
      counters_(*counters),
      detector_mutex_(detector_mutex),
      markers_(options.odom_frame, options.detector.acceptance.min_score,
               options.publish_rejected_markers) {
  loop_publisher_ = node.advertise<LoopClosure>("loop_closures", 100);
  keyframe_publisher_ =
      node.advertise<Keyframe>("keyframes", 1000);  // Bursts when the map's check passes.
  candidates_publisher_ = private_node.advertise<LoopCandidateArray>("candidates", 10);
  // Each keyframe sends only the markers it changed (queued, so none is lost); a viewer that
  // connects later is sent everything once.
  markers_publisher_ = private_node.advertise<visualization_msgs::MarkerArray>(
      "markers", 100, [this](const ros::SingleSubscriberPublisher& subscriber) {
        subscriber.publish(markers_.snapshot(ros::Time::now()));
      });
  image_transport::ImageTransport private_transport(private_node);
  // Latched: the latest loop stays on view, also for a viewer that starts later.
  match_image_publisher_ = private_transport.advertise("match_image", 1, true);
}

void NodeOutputs::forgetMap() {
  keyframe_stamps_.clear();
  markers_.clear();
}

void NodeOutputs::publishLoop(const LoopClosure& loop) {
  loop_publisher_.publish(loop);
  ++counters_.loops_published;
}

std::string NodeOutputs::expressRelativePose(const LoopDetector& detector, AcceptedLoop* loop,
                                             const std::string& camera_frame) const {
  if (options_.relative_pose_frame != RelativePoseFrame::kBase || !loop->relative_pose ||
      !loop->relative_pose->metric) {
    return camera_frame;
  }
  const std::optional<Pose>& mount = detector.cameraMount();
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

void NodeOutputs::publishKeyframe(LoopDetector& detector, const NodeKeyframe& job,
                                  const KeyframeResult& result, const cv::Mat& grey) {
  keyframe_stamps_[job.id] = job.stamp;
  keyframes_frame_id_ = job.frame_id;
  keyframes_camera_frame_ = job.image->header.frame_id;
  publishAnnounced(detector);
  if (result.loop) {
    AcceptedLoop loop = *result.loop;
    const std::string pose_frame = expressRelativePose(detector, &loop, job.image->header.frame_id);
    loop_publisher_.publish(
        toLoopMsg(loop, job.stamp, stampOf(detector, loop.match_id), job.frame_id, pose_frame));
    ++counters_.loops_published;
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
    candidates_publisher_.publish(
        toCandidatesMsg(result, detector.map().mapId(), job.stamp, job.frame_id, [&](uint64_t id) {
          detector_mutex_.assertHeld();  // Called back within this function.
          return stampOf(detector, id);
        }));
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
    const KeyframeSummary* match = detector.database().findSummary(candidate.match_id);
    if (match && match->session == detector.session()) {
      markers_.addRejected(job.pose, match->pose);
    }
  }
  // Taken every keyframe (the change set restarts), sent when someone listens.
  const visualization_msgs::MarkerArray changed = markers_.changes(job.stamp);
  if (!changed.markers.empty() && markers_publisher_.getNumSubscribers() > 0) {
    markers_publisher_.publish(changed);
  }
  publishMatchImage(detector, job, result, grey);
}

void NodeOutputs::publishMatchImage(const LoopDetector& detector, const NodeKeyframe& job,
                                    const KeyframeResult& result, const cv::Mat& grey) {
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
      detector.database().findRecord(result.keyframe_id);
  const std::shared_ptr<const KeyframeRecord> match = detector.database().findRecord(match_id);
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

ros::Time NodeOutputs::stampOf(const LoopDetector& detector, uint64_t id) const {
  const auto known = keyframe_stamps_.find(id);
  if (known != keyframe_stamps_.end()) return known->second;
  // A loaded keyframe's from its record: the map keeps stamps to the nanosecond.
  if (const std::optional<int64_t> stamp_ns = detector.map().keyframeStampNs(id);
      stamp_ns && *stamp_ns >= 0) {
    ros::Time stamp;
    stamp.fromNSec(static_cast<uint64_t>(*stamp_ns));
    return stamp;
  }
  const KeyframeSummary* summary = detector.database().findSummary(id);
  return summary ? ros::Time(summary->stamp) : ros::Time();
}

void NodeOutputs::publishAnnounced(LoopDetector& detector) {
  for (const AnnouncedKeyframe& keyframe : detector.map().takeAnnounced()) {
    // Stored while ROS shuts down: roscpp drops what its connections have not sent yet, so it may
    // never reach a subscriber (ros::ok() stays true until the connections are gone). Counted,
    // and said at shutdown.
    if (!ros::ok() || ros::isShuttingDown()) ++counters_.keyframes_unpublished_at_shutdown;
    const KeyframeSummary& summary = keyframe.summary;
    keyframe_publisher_.publish(toKeyframeMsg(summary.id, summary.session, keyframe.map_id,
                                              stampOf(detector, summary.id), summary.pose,
                                              keyframes_frame_id_));
    if (fleet_) fleet_->onAnnounced(detector, summary.id, keyframes_frame_id_);
  }
}

}  // namespace landmark_loop_closure
