#include "landmark_loop_closure/core/online_training.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <future>

namespace landmark_loop_closure {

bool needsOnlineTraining(const DescriptorOptions& options) {
  return options.type == "broad" && options.broad.online_training_keyframes > 0 &&
         !options.broad.model.empty() && !std::filesystem::exists(options.broad.model);
}

OnlineBroadTraining::OnlineBroadTraining(int keyframes, std::string model_path,
                                         BroadOptions options)
    : keyframes_(keyframes), model_path_(std::move(model_path)), options_(options) {}

void OnlineBroadTraining::hold(HeldKeyframe keyframe) {
  keyframe.image = keyframe.image.clone();  // The caller's buffer may be reused.
  keyframe.depth = keyframe.depth.clone();
  held_.push_back(std::move(keyframe));
  if (started() || held() < keyframes_) return;
  std::vector<cv::Mat> images;
  for (const HeldKeyframe& frame : held_) images.push_back(frame.image);
  result_ = std::async(std::launch::async, [images = std::move(images), options = options_,
                                            path = model_path_, this]() {
    const auto start = std::chrono::steady_clock::now();
    BroadTrainer trainer(options);
    Eigen::MatrixXf inputs(static_cast<Eigen::Index>(images.size()),
                           trainer.model().inputDimension());
    for (size_t i = 0; i < images.size(); ++i) {
      inputs.row(static_cast<Eigen::Index>(i)) = trainer.model().preprocess(images[i]);
    }
    trainer.train(inputs);
    trainer.model().save(path);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    char text[512];
    std::snprintf(text, sizeof(text),
                  "broad autoencoder trained on %zu keyframes in %.1f s (reconstruction "
                  "error %.4f), written to %s",
                  images.size(), seconds, trainer.trainingError(), path.c_str());
    summary_ = text;  // Read only after the future is ready.
    return std::shared_ptr<const DescriptorExtractor>(
        std::make_shared<BroadDescriptor>(trainer.model()));
  });
}

bool OnlineBroadTraining::ready() const {
  return started() && result_.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

bool OnlineBroadTraining::waitUntilReady(double seconds) const {
  return started() &&
         result_.wait_for(std::chrono::duration<double>(seconds)) == std::future_status::ready;
}

std::shared_ptr<const DescriptorExtractor> OnlineBroadTraining::finish() { return result_.get(); }

std::vector<HeldKeyframe> OnlineBroadTraining::release() {
  std::vector<HeldKeyframe> released = std::move(held_);
  held_.clear();
  return released;
}

}  // namespace landmark_loop_closure
