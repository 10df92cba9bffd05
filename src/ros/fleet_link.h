// The detector's link to other robots over ROS (fleet/): its stored keyframes' rows published on
// ~shared_keyframes and its keyframes' evidence answered on ~keyframe_evidence (at a bounded rate
// per caller); the peers' rows kept and searched (FleetMatcher) on the link's own thread, never
// the worker's; a chained candidate's evidence fetched from its robot over that robot's
// EvidenceChannel, checked with the detector free but for the thumbnails' network pass, and the
// loop published as any other.
#pragma once

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include "evidence_channel.h"
#include "landmark_loop_closure/FleetEvidence.h"
#include "landmark_loop_closure/FleetKeyframe.h"
#include "landmark_loop_closure/LoopClosure.h"
#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/core/input_error.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/fleet/fleet_matcher.h"
#include "landmark_loop_closure/fleet/fleet_searcher.h"
#include "landmark_loop_closure/fleet/request_rate.h"

namespace landmark_loop_closure {

/// What the link counts, for its diagnostics: any thread adds.
struct FleetCounters {
  std::atomic<uint64_t> rows_shared{0};
  std::atomic<uint64_t> backlog_rows_sent{0};
  std::atomic<uint64_t> fetches_skipped{0};     ///< Its robot's channel had one out.
  std::atomic<uint64_t> fetches_backed_off{0};  ///< Its robot's answers were of no use.
  std::atomic<uint64_t> fetches_made{0};
  std::atomic<uint64_t> fetches_failed{0};
  std::atomic<uint64_t> evidence_bytes{0};
  std::atomic<uint64_t> loops_refused{0};
  std::atomic<uint64_t> loops_published{0};
  std::atomic<uint64_t> evidence_answered{0};
  std::atomic<uint64_t> evidence_refused{0};  ///< Past a caller's rate.
};

class FleetLink {
 public:
  /// What the link asks of the node.
  struct Hooks {
    /// Runs `action` with the detector held (DetectorRuntime::withDetector).
    std::function<void(const std::function<void(LoopDetector&)>&)> with_detector;
    /// The latest camera_info's intrinsics (invalid until one came).
    std::function<CameraIntrinsics()> intrinsics;
    /// The robot's base frame (base_frame), and, detector held, its camera's optical frame.
    std::string base_frame;
    std::function<std::string()> camera_frame;
    /// Puts the loop's relative pose in the frame relative_pose_frame asks for; returns it.
    std::function<std::string(AcceptedLoop*)> express_relative_pose;
    /// Publishes a loop between robots on loop_closures.
    std::function<void(const LoopClosure&)> publish_loop;
  };

  /// `detector` (held by the caller) gives the descriptor identity and the evidence's limits.
  FleetLink(ros::NodeHandle node, ros::NodeHandle private_node, const FleetOptions& options,
            const LoopDetector& detector, Hooks hooks);
  ~FleetLink();
  FleetLink(const FleetLink&) = delete;
  FleetLink& operator=(const FleetLink&) = delete;

  /// Stops answering and fetching (before the detector's worker stops).
  void stop();

  /// Worker thread, detector held: keyframe `id` was just announced (committed): shared with
  /// the peers, and handed to the link's thread to be searched in theirs (the worker does not
  /// wait for the search).
  void onAnnounced(LoopDetector& detector, uint64_t id, const std::string& odometry_frame);

  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);

 private:
  void onRow(const std::string& peer, const FleetKeyframe::ConstPtr& msg);
  /// Backlog thread: a peer that subscribed is sent the rows of the map so far (paced).
  void sendBacklog(const ros::SingleSubscriberPublisher& subscriber);
  bool onEvidence(ros::ServiceEvent<FleetEvidence::Request, FleetEvidence::Response>& event);
  /// The searcher's thread: an own keyframe's candidate handed to its robot's channel.
  void fetch(const FleetSearcher::Search& own, const FleetCandidate& candidate);
  /// A channel's thread: the candidate's evidence as it came, checked and the loop published;
  /// false when the answer was of no use (none, "not found", malformed).
  bool checkFetched(const FleetCandidate& candidate, const std::string& odometry_frame,
                    const std::string& service, const EvidenceChannel::Answer& answer);

  ros::NodeHandle node_;
  ros::NodeHandle private_node_;
  FleetOptions options_;
  std::string robot_;
  Hooks hooks_;
  ros::Publisher row_publisher_;
  std::vector<ros::Subscriber> row_subscribers_;
  ros::CallbackQueue service_queue_;
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
  ros::CallbackQueue backlog_queue_;  ///< Its own thread: a long backlog delays no answer.
  std::unique_ptr<ros::AsyncSpinner> backlog_spinner_;
  std::atomic<bool> backlog_stopping_{false};
  Mutex odometry_frame_mutex_;
  /// Of the last keyframe shared, for the backlog's rows.
  std::string last_odometry_frame_ GUARDED_BY(odometry_frame_mutex_);
  ros::ServiceServer evidence_service_;
  ros::WallTimer silence_timer_;

  Mutex matcher_mutex_;
  std::unique_ptr<FleetMatcher> matcher_ PT_GUARDED_BY(matcher_mutex_);
  KindThrottle refusals_{10.0};  ///< Callback thread only: refused rows, by peer and reason.
  std::atomic<uint64_t> own_map_id_{0};

  std::map<std::string, std::unique_ptr<EvidenceChannel>> channels_;  ///< By peer; fixed at start.
  RequestRate evidence_rate_;                                         ///< Service thread only.
  KindThrottle evidence_refusals_{10.0};                              ///< Service thread only.

  std::unique_ptr<FleetSearcher> searcher_;  ///< With peers: their rows searched off the worker.

  FleetCounters counters_;
};

}  // namespace landmark_loop_closure
