// The description stage of the loop detector: the extractor's descriptor of a keyframe, its
// global vector standardised against the camera's recent keyframes (ConditionStandardiser), and
// the keyframes held back while that window is still filling.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/core/condition_standardiser.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {

/// Not thread-safe: the detector's worker owns it.
class KeyframeDescriber {
 public:
  /// `extractor` may be null only for the detector to refuse it (hasExtractor()).
  KeyframeDescriber(std::shared_ptr<const DescriptorExtractor> extractor,
                    const DescriptorOptions& options);

  bool hasExtractor() const { return extractor_ != nullptr; }
  const DescriptorExtractor& extractor() const { return *extractor_; }
  const DescriptorExtractor* extractorPointer() const { return extractor_.get(); }
  /// What a saved map must have been made with: the extractor's name and the options that shape
  /// its vectors (descriptorIdentity()); empty without an extractor.
  const std::string& identity() const { return identity_; }

  /// The extractor's descriptor with its global vector standardised; `raw_global` (optional)
  /// receives the vector before standardisation.
  ImageDescriptor describe(const cv::Mat& image, std::vector<float>* raw_global = nullptr);

  /// The standardisation window is not full yet: a keyframe described now leans on too few
  /// keyframes to be stored as it is (hold() it).
  bool warmingUp() const { return standardiser_.warmingUp(); }
  /// Keeps a keyframe described while warming up, with its vector before standardisation.
  void hold(KeyframeRecord keyframe, std::vector<float> raw_global);
  bool holding() const { return !held_.empty(); }
  /// The keyframes held, oldest first, each described again by the window as it is now when it
  /// is full (as they are, otherwise: a save, a map switch or the end came first); none are held
  /// afterwards.
  std::vector<KeyframeRecord> takeHeld();

  /// The last keyframe's standardised global vector (score normalisation's previous_keyframe);
  /// empty before the first.
  const std::vector<float>& previousGlobal() const { return previous_global_; }
  void setPreviousGlobal(const std::vector<float>& global) { previous_global_ = global; }

 private:
  struct HeldKeyframe {
    KeyframeRecord keyframe;
    std::vector<float> raw_global;
  };

  std::shared_ptr<const DescriptorExtractor> extractor_;
  std::string identity_;
  ConditionStandardiser standardiser_;
  std::vector<HeldKeyframe> held_;
  std::vector<float> previous_global_;
};

}  // namespace landmark_loop_closure
