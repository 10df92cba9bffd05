// The pose graph as a running service, without ROS: inputs are queued on the caller's thread,
// which never waits for an optimisation; one worker thread takes whatever came meanwhile into
// the PoseGraphSession and tells the listener. map -> odom is readable from any thread.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "landmark_loop_closure/backend/pose_graph_session.h"
#include "landmark_loop_closure/common/thread_annotations.h"

namespace landmark_loop_closure {

/// Called on the worker thread; the session is the worker's own until the call returns.
struct PoseGraphListener {
  /// A batch of inputs went into the graph.
  std::function<void(PoseGraphSession&, const GraphStep&)> step;
  /// No input came for the catch-up time and the last paths miss keyframes (the robot stopped,
  /// the bag ended): the paths should show every keyframe.
  std::function<void(PoseGraphSession&)> catch_up;
  /// An exception escaped a batch (Ceres, a listener): the batch's remaining work is dropped and
  /// the worker goes on with the next one. `what` is the exception's.
  std::function<void(const std::string& what)> failed;
  /// A line about the saved graph (options.graph_file): restored from it, or why it is not used
  /// or could not be written (`problem` true: a warning).
  std::function<void(const std::string& text, bool problem)> graph_file;
};

/// map_frame -> the odometry frame, and that frame's name.
struct GraphCorrection {
  Eigen::Isometry3d map_from_odometry = Eigen::Isometry3d::Identity();
  std::string odometry_frame;
};

class PoseGraphRuntime {
 public:
  /// Starts the worker.
  PoseGraphRuntime(PoseGraphNodeOptions options, MountLookup mount, PoseGraphListener listener,
                   std::chrono::milliseconds catch_up = std::chrono::seconds(1));
  /// stop().
  ~PoseGraphRuntime();
  PoseGraphRuntime(const PoseGraphRuntime&) = delete;
  PoseGraphRuntime& operator=(const PoseGraphRuntime&) = delete;

  /// Any thread; returns at once.
  void push(PoseGraphSession::Input input);
  /// Any thread: the correction after the last keyframe that entered; nullopt before the first.
  std::optional<GraphCorrection> correction() const;
  /// Any thread: the correction of every odometry frame keyframes came in (robots sharing the
  /// graph), each at its newest keyframe.
  std::vector<GraphCorrection> corrections() const;
  /// Joins the worker; inputs still queued are not processed; the graph is saved
  /// (options.graph_file). Idempotent.
  void stop();
  /// After stop(): PoseGraphSession::summary().
  std::string summary() const;
  /// Batches (or catch-ups) an exception ended; the worker went on.
  uint64_t failures() const { return failures_; }

 private:
  void work();
  void process(const std::vector<PoseGraphSession::Input>& batch);
  /// On the worker, before any input: the saved graph replayed.
  void restore();
  /// Writes the graph to options.graph_file unless that file could not be read at start (it is
  /// left as it was found) or nothing is in the graph.
  void save();
  void tell(const std::string& text, bool problem);

  /// The correction and the listener after a step.
  void publish(const GraphStep& step);

  PoseGraphSession session_;
  PoseGraphListener listener_;
  const std::chrono::milliseconds catch_up_;
  static constexpr std::chrono::seconds kSaveInterval{10};
  const std::string graph_file_;
  bool graph_file_refused_ = false;  ///< Unreadable at start: never written.
  std::chrono::steady_clock::time_point last_save_;
  uint64_t saved_revision_ = 0;  ///< keptRevision() the file holds.

  mutable Mutex correction_mutex_;
  std::optional<GraphCorrection> correction_ GUARDED_BY(correction_mutex_);
  std::vector<GraphCorrection> corrections_ GUARDED_BY(correction_mutex_);

  Mutex mutex_;
  std::condition_variable wake_;
  std::vector<PoseGraphSession::Input> inputs_ GUARDED_BY(mutex_);
  bool stopping_ GUARDED_BY(mutex_) = false;
  std::atomic<uint64_t> failures_{0};
  std::thread worker_;
};

}  // namespace landmark_loop_closure
