#include "landmark_loop_closure/descriptor.h"

#include <algorithm>
#include <stdexcept>

#include <Eigen/Core>

#include "landmark_loop_closure/baseline_descriptors.h"
#include "landmark_loop_closure/hog_descriptor.h"

namespace landmark_loop_closure {

size_t ImageDescriptor::bytes() const {
  return global.size() * sizeof(float) + landmark_boxes.size() * sizeof(cv::Rect2f) +
         landmark_features.total() * landmark_features.elemSize();
}

double cosineSimilarity(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size() || a.empty()) return 0.0;
  const Eigen::Map<const Eigen::VectorXf> va(a.data(), static_cast<Eigen::Index>(a.size()));
  const Eigen::Map<const Eigen::VectorXf> vb(b.data(), static_cast<Eigen::Index>(b.size()));
  return static_cast<double>(va.dot(vb));
}

double DescriptorExtractor::similarity(const ImageDescriptor& query,
                                       const ImageDescriptor& candidate) const {
  return cosineSimilarity(query.global, candidate.global);
}

const std::vector<std::string>& descriptorTypes() {
  static const std::vector<std::string> types = {"hog", "hog_whole", "pixels"};
  return types;
}

std::string DescriptorOptions::validate() const {
  const auto& types = descriptorTypes();
  if (std::find(types.begin(), types.end(), type) != types.end()) return {};
  std::string known;
  for (const std::string& name : types) known += (known.empty() ? "" : ", ") + name;
  return "descriptor/type must be one of: " + known + " (got '" + type + "')\n";
}

std::shared_ptr<const DescriptorExtractor> makeDescriptorExtractor(
    const DescriptorOptions& options) {
  if (options.type == "hog") return std::make_shared<HogDescriptor>();
  if (options.type == "hog_whole") return std::make_shared<WholeImageHogDescriptor>();
  if (options.type == "pixels") return std::make_shared<PixelDescriptor>();
  throw std::invalid_argument("unknown descriptor type '" + options.type + "'");
}

}  // namespace landmark_loop_closure
