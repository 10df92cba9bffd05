// The detector as a running service, without ROS: frames are admitted on the caller's thread
// (cheap checks and the keyframe rule), keyframes go through a bounded queue to one worker thread
// that describes and searches them, so the caller never waits. It owns the drop policy (the
// oldest queued keyframe goes when the queue is full), time jumping back (drop the frame, or start
// a new timeline), and the lock the map services share with
// the worker. The node only feeds it and listens.
#pragma once

#include <any>
#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/runtime/bounded_queue.h"

namespace landmark_loop_closure {

enum class TimeJumpPolicy {
  kDrop,   ///< Frames stamped before the last keyframe are refused (kStampNotIncreasing).
  kReset,  ///< A jump back of more than time_jump_back_s forgets the map and starts over.
};

struct RuntimeOptions {
  size_t queue_size = 8;  ///< Keyframes waiting for the worker; when full the oldest is dropped.
  TimeJumpPolicy time_jump_back = TimeJumpPolicy::kDrop;
  double time_jump_back_s = 1.0;
  /// This many frames in a row not after the last keyframe are a time jump, whatever their size
  /// (that keyframe's stamp was wrong, or the clock went back): the next frame starts a new
  /// timeline, keeping the map (kDrop) or forgetting it (kReset), instead of every later frame
  /// being dropped until time passes that stamp. 0: off.
  size_t time_jump_frames = 30;
  /// A frame stamped more than this ahead of FrameInput::clock is refused before it can become a
  /// keyframe: every later frame would otherwise be "not after the last keyframe" until the
  /// clock caught up. 0: off.
  double max_stamp_ahead_s = 0.0;
};

/// A keyframe on its way to the worker. `source` is the caller's own (the node keeps its image
/// message there); the runtime only hands it back.
struct KeyframeJob {
  uint64_t id = 0;
  double stamp = 0.0;
  int64_t stamp_ns = 0;  ///< FrameInput::stamp_ns.
  Pose pose;
  CameraIntrinsics intrinsics;
  std::any source;
  uint64_t generation = 0;  ///< The timeline it was admitted in.
  uint64_t map_epoch = 0;   ///< The map it was admitted against (a load or reset starts another).
  bool odometry_restarted = false;  ///< Re-anchored after odometry jumps: a new session.
};

/// A frame as the caller receives it.
struct FrameInput {
  double stamp = 0.0;
  /// The stamp exactly, in nanoseconds (a message's stamp), kept in the map; 0: `stamp` rounded.
  int64_t stamp_ns = 0;
  Pose pose;
  int width = 0;
  int height = 0;
  int cv_type = 0;
  CameraIntrinsics intrinsics;
  std::any source;
  /// The receiver's clock when the frame came (wall or simulated), seconds; 0 or less: unknown
  /// (a simulated clock not started yet), no check.
  double clock = 0.0;
  /// The odometry up to this frame, when the caller holds it (a camera gap is no jump); called
  /// within admit() only.
  OdometrySince odometry_since;
};

struct RuntimeAdmission {
  FrameAdmission admission;
  /// The stamps jumped back by this many seconds and the map will be forgotten (kReset).
  std::optional<double> timeline_restarted_after_s;
  /// RuntimeOptions::time_jump_frames frames in a row were not after the last keyframe (stamped
  /// this many seconds after this frame): this frame started a new timeline; `map_forgotten`
  /// under kReset.
  std::optional<double> time_jump_after_frames_s;
  bool map_forgotten = false;
  bool queued = false;          ///< A keyframe, handed to the worker.
  bool dropped_oldest = false;  ///< ...which pushed the oldest queued keyframe out.
};

/// The worker's images for one keyframe.
struct PreparedKeyframe {
  cv::Mat image;  ///< Grey, or BGR when the descriptor asked for colour.
  cv::Mat grey;   ///< Always grey (match images).
  cv::Mat depth;  ///< Registered depth, or empty.
  /// Set: the camera mount to give the detector before this keyframe (nullopt inside: not known
  /// any more). Looked up while preparing, given with the detector locked, so that no thread
  /// reading the mount (the fleet link, a service) races the worker.
  std::optional<std::optional<Pose>> camera_mount;
};

/// What the runtime calls back, all on the worker thread: prepare() with the detector free (a
/// service may run meanwhile), the others with the detector locked.
struct RuntimeListener {
  /// The images of a job: false (and `error` set) refuses it.
  std::function<bool(const KeyframeJob&, bool wants_colour, PreparedKeyframe*, InputError*)>
      prepare;
  /// A job or keyframe refused by prepare() or by the detector.
  std::function<void(const InputError&)> rejected;
  /// The first keyframe of a new timeline: the map was just forgotten.
  std::function<void()> timeline_reset;
  /// A keyframe described, searched and (in mapping mode) stored.
  std::function<void(const KeyframeJob&, const KeyframeResult&, const PreparedKeyframe&)> keyframe;
  /// An exception escaped the work on this job (OpenCV, oneDNN, SQLite, a listener): the job is
  /// dropped where it was and the worker goes on with the next one. `what` is the exception's.
  std::function<void(const KeyframeJob&, const std::string& what)> failed;
};

class DetectorRuntime {
 public:
  /// Starts the worker. `detector` must outlive the runtime.
  DetectorRuntime(LoopDetector* detector, const RuntimeOptions& options, RuntimeListener listener);
  /// stop().
  ~DetectorRuntime();
  DetectorRuntime(const DetectorRuntime&) = delete;
  DetectorRuntime& operator=(const DetectorRuntime&) = delete;

  /// Caller's thread: input checks, time jumps and the keyframe rule; keyframes are queued.
  /// Any thread: the next admitted frame starts the keyframe rule afresh, whatever its stamp
  /// (after ~reset: the old timeline's last keyframe no longer bounds the new one's stamps).
  void restartTimeline() { restart_timeline_ = true; }
  RuntimeAdmission admit(FrameInput frame);

  /// Runs `action` on the detector with the worker held off (map services). `action` returns
  /// true when it replaced or forgot the map: the keyframes queued before it are dropped (their ids
  /// and stamps were given against the previous map); returns how many were queued then.
  size_t withDetector(const std::function<bool(LoopDetector&)>& action)
      EXCLUDES(detector_mutex_, read_only_handler);
  /// The same when the detector is free now; false (nothing run) while a keyframe or service
  /// holds it, so a timer never waits on the worker.
  bool tryWithDetector(const std::function<bool(LoopDetector&)>& action)
      EXCLUDES(detector_mutex_, read_only_handler);

  /// The lock withDetector() and the listener's callbacks run under: what the caller keeps for
  /// the detector (state read and written only with it) is guarded by it.
  const Mutex& detectorMutex() const RETURN_CAPABILITY(detector_mutex_) { return detector_mutex_; }

  /// What saveMap() did.
  struct SaveOutcome {
    std::string error;     ///< "" on success.
    std::string target;    ///< The file written (the open map's own path for "").
    bool own_map = false;  ///< `target` is the open map: committed and checkpointed.
    size_t keyframes = 0;  ///< In the saved map.
    std::string kept_as;   ///< Where an overwritten map was kept.
  };
  /// Any thread but the worker's (map services): saves as MapSession::save() says,
  /// `path` "" meaning the open map. A copy goes step by step (MapSession::beginSave: 2048
  /// SQLite pages, ~4 MB, per hold of the detector), the rows file and the rename with the
  /// detector free, so the worker keeps describing keyframes meanwhile.
  SaveOutcome saveMap(const std::string& path, bool overwrite)
      EXCLUDES(detector_mutex_, read_only_handler);

  /// Stops the worker after the keyframe in hand; queued keyframes are dropped. Idempotent.
  void stop();

  uint64_t keyframesDropped() const { return dropped_; }
  /// Time jumps found by time_jump_frames (each started a new timeline).
  uint64_t timeJumps() const { return time_jumps_; }
  uint64_t staleKeyframesDropped() const { return stale_; }
  /// Keyframes queued before a load or reset replaced the map, dropped by the worker.
  uint64_t keyframesDroppedAtMapSwitch() const { return dropped_at_map_switch_; }
  /// Jobs an exception ended (listener.failed said which); the worker went on.
  uint64_t keyframesFailed() const { return failed_; }
  size_t queued() const { return queue_.size(); }
  /// Worker time of the last keyframe and the longest so far, in milliseconds.
  double lastProcessingMs() const { return last_ms_; }
  double maxProcessingMs() const { return max_ms_; }

 private:
  void work() EXCLUDES(detector_mutex_);
  void process(KeyframeJob& job) EXCLUDES(detector_mutex_);
  /// withDetector()'s work.
  size_t runOnDetector(const std::function<bool(LoopDetector&)>& action) REQUIRES(detector_mutex_);

  /// Held by the worker for a keyframe's description, search and storing, and by each map
  /// service; never by admit().
  Mutex detector_mutex_;
  LoopDetector* const detector_ PT_GUARDED_BY(detector_mutex_);
  /// The detector's receiving-thread part: admit() uses it without the lock.
  KeyframeAdmission* const admission_;
  const bool wants_colour_;  ///< The extractor's, fixed for the detector's life.
  const RuntimeOptions options_;
  const RuntimeListener listener_;
  BoundedQueue<KeyframeJob> queue_;
  std::atomic<uint64_t> generation_{0};  ///< Bumped on each time jump back (kReset).
  std::atomic<bool> restart_timeline_{false};
  size_t not_increasing_in_a_row_ = 0;  ///< Caller's thread (admit).
  std::atomic<uint64_t> time_jumps_{0};
  uint64_t worker_generation_ GUARDED_BY(detector_mutex_) = 0;  ///< The timeline the worker is in.
  std::atomic<uint64_t> dropped_{0};
  std::atomic<uint64_t> stale_{0};
  std::atomic<uint64_t> map_epoch_{0};  ///< Bumped when a map service replaced the map.
  std::atomic<uint64_t> dropped_at_map_switch_{0};
  std::atomic<uint64_t> failed_{0};
  std::atomic<double> last_ms_{0.0};
  std::atomic<double> max_ms_{0.0};
  std::thread worker_;
};

}  // namespace landmark_loop_closure
