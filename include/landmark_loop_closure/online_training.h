#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/broad_autoencoder.h"
#include "landmark_loop_closure/metric_pose.h"
#include "landmark_loop_closure/pose.h"

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
};

/// Online mode of the broad autoencoder: holds the first N keyframes, then trains on them, writes
/// the model to descriptor/broad/model and hands the held keyframes back to be described.
class OnlineBroadTraining {
 public:
  OnlineBroadTraining(int keyframes, std::string model_path, BroadOptions options = {});

  /// Holds a copy of the keyframe; true once enough are held to train.
  bool hold(HeldKeyframe keyframe);
  /// Trains on the held keyframes and writes the model file. Throws what training throws.
  std::shared_ptr<const DescriptorExtractor> train();
  /// The held keyframes, oldest first (emptied).
  std::vector<HeldKeyframe> release();
  void clear() { held_.clear(); }

  int held() const { return static_cast<int>(held_.size()); }
  int wanted() const { return keyframes_; }
  /// "trained on N keyframes in S s, written to PATH" after train().
  const std::string& summary() const { return summary_; }

 private:
  int keyframes_;
  std::string model_path_;
  BroadOptions options_;
  std::vector<HeldKeyframe> held_;
  std::string summary_;
};

}  // namespace landmark_loop_closure
