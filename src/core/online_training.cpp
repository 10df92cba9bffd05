#include "landmark_loop_closure/online_training.h"

#include <chrono>
#include <cstdio>
#include <filesystem>

namespace landmark_loop_closure {

bool needsOnlineTraining(const DescriptorOptions& options) {
  return options.type == "broad" && options.broad.online_training_keyframes > 0 &&
         !options.broad.model.empty() && !std::filesystem::exists(options.broad.model);
}

OnlineBroadTraining::OnlineBroadTraining(int keyframes, std::string model_path,
                                         BroadOptions options)
    : keyframes_(keyframes), model_path_(std::move(model_path)), options_(options) {}

bool OnlineBroadTraining::hold(HeldKeyframe keyframe) {
  keyframe.image = keyframe.image.clone();  // The caller's buffer may be reused.
  keyframe.depth = keyframe.depth.clone();
  held_.push_back(std::move(keyframe));
  return held() >= keyframes_;
}

std::shared_ptr<const DescriptorExtractor> OnlineBroadTraining::train() {
  const auto start = std::chrono::steady_clock::now();
  BroadTrainer trainer(options_);
  Eigen::MatrixXf inputs(held(), trainer.model().inputDimension());
  for (int i = 0; i < held(); ++i) inputs.row(i) = trainer.model().preprocess(held_[i].image);
  trainer.train(inputs);
  trainer.model().save(model_path_);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  char text[512];
  std::snprintf(text, sizeof(text),
                "broad autoencoder trained on %d keyframes in %.1f s (reconstruction error "
                "%.4f), written to %s",
                held(), seconds, trainer.trainingError(), model_path_.c_str());
  summary_ = text;
  return std::make_shared<BroadDescriptor>(trainer.model());
}

std::vector<HeldKeyframe> OnlineBroadTraining::release() {
  std::vector<HeldKeyframe> released = std::move(held_);
  held_.clear();
  return released;
}

}  // namespace landmark_loop_closure
