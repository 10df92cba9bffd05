#include "landmark_loop_closure/core/keyframe_describer.h"

#include <utility>

namespace landmark_loop_closure {

KeyframeDescriber::KeyframeDescriber(std::shared_ptr<const DescriptorExtractor> extractor,
                                     const DescriptorOptions& options)
    : extractor_(std::move(extractor)),
      identity_(extractor_ ? "extractor=" + extractor_->name() + " " + descriptorIdentity(options)
                           : std::string()),
      standardiser_(options.condition_window) {}

ImageDescriptor KeyframeDescriber::describe(const cv::Mat& image, std::vector<float>* raw_global) {
  ImageDescriptor descriptor = extractor_->describe(image);
  if (raw_global) *raw_global = descriptor.global;
  descriptor.global = standardiser_.apply(descriptor.global);
  return descriptor;
}

void KeyframeDescriber::hold(KeyframeRecord keyframe, std::vector<float> raw_global) {
  held_.push_back({std::move(keyframe), std::move(raw_global)});
}

std::vector<KeyframeRecord> KeyframeDescriber::takeHeld() {
  std::vector<HeldKeyframe> held = std::move(held_);
  held_.clear();
  std::vector<KeyframeRecord> keyframes;
  keyframes.reserve(held.size());
  for (HeldKeyframe& waiting : held) {
    if (!standardiser_.warmingUp()) {
      waiting.keyframe.descriptor.global = standardiser_.standardise(waiting.raw_global);
    }
    keyframes.push_back(std::move(waiting.keyframe));
  }
  return keyframes;
}

}  // namespace landmark_loop_closure
