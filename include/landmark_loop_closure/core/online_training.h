#pragma once

#include <future>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/descriptors/broad_autoencoder.h"
#include "landmark_loop_closure/geometry/metric_pose.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

/// Whether options ask the detector to train its broad autoencoder on the session's first
/// keyframes: type broad, broad.online_training_keyframes > 0, and no model file yet.
bool needsOnlineTraining(const DescriptorOptions& options);

/// A keyframe held back until the descriptor exists.
struct HeldKeyframe {
  uint64_t id = 0;
  double stamp = 0.0;
  Pose pose;
  cv::Mat image;
  CameraIntrinsics intrinsics;
  cv::Mat depth;
  int64_t stamp_ns = 0;  ///< LoopDetector::addKeyframe's.
};

/// Online mode of the broad autoencoder: holds the first N keyframes, trains on them in a
/// background thread while later keyframes are held too, writes the model to
/// advanced/descriptor/broad/model and hands every held keyframe back to be described.
class OnlineBroadTraining {
 public:
  OnlineBroadTraining(int keyframes, std::string model_path, BroadOptions options = {});

  /// Holds a copy of the keyframe; starts training once `keyframes` are held.
  void hold(HeldKeyframe keyframe);
  /// True once training has finished (successfully or not); finish() then returns at once.
  bool ready() const;
  /// Waits up to `seconds` for a started training; true when it has finished.
  bool waitUntilReady(double seconds) const;
  /// The trained extractor (the model file is written). Throws what training threw.
  std::shared_ptr<const DescriptorExtractor> finish();
  /// The held keyframes, oldest first (emptied).
  std::vector<HeldKeyframe> release();
  /// Forgets the held keyframes (a running training goes on).
  void clear() { held_.clear(); }

  int held() const { return static_cast<int>(held_.size()); }
  int wanted() const { return keyframes_; }
  bool started() const { return result_.valid(); }
  /// "trained on N keyframes in S s, written to PATH" after finish().
  const std::string& summary() const { return summary_; }

 private:
  int keyframes_;
  std::string model_path_;
  BroadOptions options_;
  std::vector<HeldKeyframe> held_;
  std::string summary_;  // Written by the training thread: declared before result_, whose
                         // destructor waits for that thread.
  std::future<std::shared_ptr<const DescriptorExtractor>> result_;
};

}  // namespace landmark_loop_closure
