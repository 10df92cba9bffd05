#pragma once

#include <atomic>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>

#include <diagnostic_updater/diagnostic_updater.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "fleet_link.h"
#include "landmark_loop_closure/DatabaseFile.h"
#include "landmark_loop_closure/ResetDatabase.h"
#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/core/input_error.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/runtime/detector_runtime.h"
#include "landmark_loop_closure/runtime/input_monitor.h"
#include "landmark_loop_closure/runtime/odometry_history.h"
#include "landmark_loop_closure/runtime/stamped_buffer.h"
#include "loop_markers.h"

namespace landmark_loop_closure {

/// Reads the node's options from its private namespace. Throws std::invalid_argument listing
/// every problem (type errors and validation); warns about keys it does not know.
NodeOptions loadNodeOptions(const ros::NodeHandle& private_node);

/// The ROS side of the detector: subscriptions, a worker thread, publishers, diagnostics.
///
/// Threading: subscriber and timer callbacks run on the node handles' single-threaded queue and
/// only do cheap checks and keyframe selection; describing and searching run on the
/// DetectorRuntime's worker thread, whose callbacks publish the results, so a callback never
/// waits for it.
/// The diagnostics' summary while the map file refuses writes: "map file full: N keyframes not
/// stored (why)" for a full disk, "map file not written: ..." otherwise.
std::string mapWriteSummary(const std::string& problem, size_t keyframes_not_stored);

class LoopClosureNode {
 public:
  /// Throws std::runtime_error when the map at database_path cannot be opened.
  LoopClosureNode(ros::NodeHandle node, ros::NodeHandle private_node, const NodeOptions& options);
  ~LoopClosureNode();

  LoopClosureNode(const LoopClosureNode&) = delete;
  LoopClosureNode& operator=(const LoopClosureNode&) = delete;

 private:
  /// What the node hands the runtime with each frame (KeyframeJob::source).
  struct FrameSource {
    sensor_msgs::ImageConstPtr image;
    std::string frame_id;  ///< The odometry frame of the pose.
  };
  /// A keyframe as the publishers need it.
  struct NodeKeyframe {
    sensor_msgs::ImageConstPtr image;
    uint64_t id;
    ros::Time stamp;  ///< The image's own stamp, to the nanosecond.
    Pose pose;
    std::string frame_id;  ///< The odometry frame of `pose`.
  };
  struct PendingImage {
    sensor_msgs::ImageConstPtr image;
    ros::WallTime received;
  };
  void subscribe();
  void onImageForOdometry(const sensor_msgs::ImageConstPtr& image);
  void onOdometry(const nav_msgs::OdometryConstPtr& odometry);
  /// Admits, in stamp order, the held images the odometry now places; drops those it never will.
  void pairPendingWithOdometry();
  /// The odometry's pose as base_frame's: through tf when child_frame_id is another frame.
  std::optional<Pose> bodyPose(const nav_msgs::Odometry& odometry);
  void onImageForTf(const sensor_msgs::ImageConstPtr& image);
  void retryPendingTf();
  void onCameraInfo(const sensor_msgs::CameraInfoConstPtr& info);
  void onDepth(const sensor_msgs::ImageConstPtr& depth);
  /// `odometry_since`: the odometry up to this image, where the node holds it (not with tf).
  void admitFrame(const sensor_msgs::ImageConstPtr& image, const Pose& pose,
                  const std::string& frame_id, OdometrySince odometry_since = nullptr);
  void reportRejected(const InputError& error);
  /// Records (and warns once per period and cause) whether camera_info suits an accepted frame.
  void noteCalibration(const std::optional<CalibrationProblem>& problem);
  /// Logs once which path the descriptor takes for images of this size (and why).
  void sayDescriptorPath(cv::Size image_size);

  // DetectorRuntime callbacks, on its worker thread with the detector locked.
  static NodeKeyframe nodeKeyframe(const KeyframeJob& job);
  bool prepareKeyframe(const KeyframeJob& job, bool colour, PreparedKeyframe* prepared,
                       InputError* error);
  void onTimelineReset();
  void onKeyframeDone(const KeyframeJob& job, const KeyframeResult& result,
                      const PreparedKeyframe& prepared);
  /// The depth image nearest `stamp` within sync_slop, waiting briefly for one still on its way;
  /// empty when none, or when it is not in `camera_frame` (unregistered) or unusable.
  cv::Mat depthFor(const ros::Time& stamp, const std::string& camera_frame);
  /// advanced/camera_mount/from_tf: looks base_frame <- `camera_frame` up until tf has it.
  /// The mount found goes into `prepared` (the runtime gives it to the detector under its lock).
  void updateCameraMount(const std::string& camera_frame, PreparedKeyframe* prepared);
  /// The loop's relative pose in the frame relative_pose_frame asks for, when possible; returns
  /// the frame it is in.
  std::string expressRelativePose(AcceptedLoop* loop, const std::string& camera_frame) const;
  void publishResults(const NodeKeyframe& job, const KeyframeResult& result, const cv::Mat& grey);
  void publishMatchImage(const NodeKeyframe& job, const KeyframeResult& result,
                         const cv::Mat& grey);
  /// Diagnostics read the map's real size and bytes: called wherever the database changes
  /// (start, keyframe, load, reset). Caller holds the detector.
  void noteMapSize(const LoopDetector& detector);
  /// One ERROR for a map found damaged (MapSession::takeNewDamage()); nothing for "".
  void reportMapDamage(const std::string& damage);
  std::string cameraInfoProblem();
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);
  static double wallNow();
  static constexpr double kWarningPeriod = 10.0;  ///< Seconds between repeats of a warning.

  // Database file. Services run on their own thread and reach the detector through
  // DetectorRuntime::withDetector, so a save or load waits for the keyframe in hand and never
  // blocks the image callbacks.
  void advertiseServices();
  bool onSaveDatabase(DatabaseFile::Request& request, DatabaseFile::Response& response);
  /// Says (log and service `message`) how many keyframes queued before a load or reset the
  /// worker drops.
  void noteDroppedAtMapSwitch(size_t dropped, const char* service, std::string* message);
  bool onLoadDatabase(DatabaseFile::Request& request, DatabaseFile::Response& response);
  bool onResetDatabase(ResetDatabase::Request& request, ResetDatabase::Response& response);
  /// The original stamp of a keyframe, to the nanosecond (a loaded one's as its map keeps it).
  ros::Time stampOf(uint64_t id) const;
  /// Worker thread (detector held): publishes the keyframes the detector says are committed
  /// (LoopDetector::takeAnnounced), so no published (map_id, id) is lost to a crash.
  void publishAnnouncedKeyframes();

  ros::NodeHandle node_;
  ros::NodeHandle private_node_;
  NodeOptions options_;
  LoopDetector detector_;

  // Inputs.
  image_transport::ImageTransport image_transport_;
  image_transport::Subscriber image_subscriber_;
  ros::Subscriber odom_subscriber_;
  // odom mode, callback thread only: recent odometry and the images waiting for it.
  OdometryHistory odometry_history_;
  std::string odometry_frame_;  ///< frame_id of the latest odometry message.
  std::deque<sensor_msgs::ImageConstPtr> pending_odometry_;
  ros::Subscriber camera_info_subscriber_;
  image_transport::Subscriber depth_subscriber_;
  InputMonitor inputs_;                        // Arrivals, pairing, bad frames: thread-safe.
  static constexpr uint32_t kDepthQueue = 30;  // Depth images the subscriber and buffer keep.
  StampedBuffer<sensor_msgs::ImageConstPtr> depth_buffer_{
      kDepthQueue};                              // Callbacks fill, worker reads.
  KindThrottle depth_warnings_{kWarningPeriod};  ///< The depth decoder's reasons, one silence each.
  std::atomic<bool> depth_silence_reported_{false};  ///< Warned of a silent depth publisher.
  Mutex stats_mutex_;  ///< Guards what the worker, the callbacks and the timers each report.
  /// One per cause.
  KindThrottle camera_info_warnings_ GUARDED_BY(stats_mutex_) = KindThrottle{kWarningPeriod};
  std::string camera_mount_frame_;     // Worker thread only: the frame the tf mount was found for.
  bool default_mount_warned_ = false;  // Worker thread only: defaultMountWarning() said.
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::deque<PendingImage> pending_tf_;
  ros::WallTimer tf_timer_;
  std::string image_topic_;
  std::string odom_topic_;

  // Outputs.
  ros::Publisher loop_publisher_;
  ros::Publisher keyframe_publisher_;
  ros::Publisher candidates_publisher_;
  ros::Publisher markers_publisher_;
  image_transport::Publisher match_image_publisher_;
  bool loop_shown_ = false;  ///< The match view holds the latest loop; worker thread only.
  LoopMarkers markers_;      // Thread-safe: the worker draws, a connecting viewer reads.
  std::unordered_map<uint64_t, ros::Time> keyframe_stamps_;  // With the detector held.
  std::string keyframes_frame_id_;      ///< The last keyframe's odometry frame; detector held.
  std::string keyframes_camera_frame_;  ///< The last keyframe's image frame; detector held.

  // Database services.
  ros::CallbackQueue service_queue_;
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
  ros::ServiceServer save_service_;
  ros::ServiceServer load_service_;
  ros::ServiceServer reset_service_;

  // Diagnostics; counters are written by both threads.
  diagnostic_updater::Updater diagnostics_;
  ros::WallTimer diagnostics_timer_;
  std::atomic<uint64_t> frames_admitted_{0};
  /// Which path the descriptor takes for these images has been logged (once, at the first
  /// image the detector was free for; again never).
  std::atomic<bool> descriptor_path_said_{false};
  std::atomic<uint64_t> map_keyframes_{0};  ///< The database's size, set wherever it changes.
  std::atomic<uint64_t> keyframes_over_budget_{0};
  std::atomic<uint64_t> loops_published_{0};
  std::atomic<uint64_t> tf_timeouts_{0};
  std::atomic<uint64_t> odometry_jumps_{0};
  std::atomic<uint64_t> keyframes_with_depth_{0};
  /// Keyframes stored while or after ROS shut down, which may not have reached subscribers (said
  /// in the last log line).
  std::atomic<uint64_t> keyframes_unpublished_at_shutdown_{0};
  std::atomic<uint64_t> keyframes_without_depth_{0};
  std::atomic<bool> camera_info_seen_{false};
  /// Why camera_info is unusable, or "".
  std::string camera_info_problem_ GUARDED_BY(stats_mutex_);
  std::atomic<uint32_t> session_{0};               // The detector's, for diagnostics.
  std::atomic<double> last_time_jump_wall_{-1e9};  ///< When time_jump_frames last restarted time.
  uint64_t drops_seen_ = 0;       // Diagnostics timer only: keyframes dropped at the last look,
  double last_drop_wall_ = -1e9;  // and when that count last grew.
  size_t database_bytes_ GUARDED_BY(stats_mutex_) = 0;
  /// From the latest camera_info; invalid until one.
  CameraIntrinsics camera_intrinsics_ GUARDED_BY(stats_mutex_);
  /// The map's path, or why it failed.
  std::string database_status_ GUARDED_BY(stats_mutex_) = "memory only";
  std::string map_check_ GUARDED_BY(stats_mutex_);          ///< MapSession::check().
  std::string map_damage_ GUARDED_BY(stats_mutex_);         ///< MapSession::damage().
  std::string map_write_problem_ GUARDED_BY(stats_mutex_);  ///< MapSession::writeProblem().
  /// MapSession::keyframesNotWritten().
  size_t keyframes_not_written_ GUARDED_BY(stats_mutex_) = 0;

  // Other robots (fleet/): null without advanced/fleet/share and advanced/fleet/peers; stopped
  // before the worker.
  std::unique_ptr<FleetLink> fleet_;
  // The worker, its queue and the detector lock; started last, stopped first.
  std::unique_ptr<DetectorRuntime> runtime_;
};

}  // namespace landmark_loop_closure
