// Shared by lcd_evaluate's image and detector modes: command-line arguments, the descriptor
// variant names ("backbone_g3x4", "landmarks_paper", "cnn_pca_c64") and the training of the
// learned descriptors.
#pragma once

#include <cstdlib>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "landmark_loop_closure/descriptors/broad_autoencoder.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/eval/evaluator.h"
#include "landmark_loop_closure/eval/training.h"
#include "landmark_loop_closure/geometry/camera_intrinsics.h"

namespace landmark_loop_closure {
namespace tools {

struct Arguments {
  /// --key value pairs; flags without a value hold "true".
  std::map<std::string, std::string> values;
  bool has(const std::string& key) const { return values.count(key) > 0; }
  std::string get(const std::string& key, const std::string& fallback = "") const {
    const auto it = values.find(key);
    return it == values.end() ? fallback : it->second;
  }
  double number(const std::string& key, double fallback) const {
    if (!has(key)) return fallback;
    char* end = nullptr;
    const double value = std::strtod(get(key).c_str(), &end);
    if (end == get(key).c_str() || *end != '\0') {
      throw std::invalid_argument(key + " needs a number, not '" + get(key) + "'");
    }
    return value;
  }
};

std::vector<std::string> splitList(const std::string& text);

/// A progress line at most every few seconds, so long runs show they are alive.
eval::Progress progressPrinter(const std::string& what);

/// The paths after the first --skip, at most --limit of them.
std::vector<std::string> limited(std::vector<std::string> paths, const Arguments& arguments);

/// Intrinsics from a ROS camera_info YAML (image_width, image_height, camera_matrix, and the lens:
/// distortion_model, distortion_coefficients);
/// throws std::runtime_error naming the file when it cannot be read or is unusable.
CameraIntrinsics readCameraInfoFile(const std::string& path);

/// A descriptor to evaluate, and how to train it when it learns from images.
struct Variant {
  DescriptorOptions options;
  int components = 256;         ///< cnn_pca: whitened dimensions.
  int whiten_components = 0;    ///< backbone_..._pcaN: the global vector whitened to N dimensions.
  bool whiten = true;           ///< false (_projN): PCA projection only, every component alike.
  int vocabulary_clusters = 0;  ///< backbone_vladK: a VLAD vocabulary of K centres learnt first.
  BroadOptions broad;
};

/// "landmarks_paper_grid2_m30" -> type landmarks, paper weighting, grid 2, 30 landmarks; see
/// lcd_evaluate --help for every name. `base`: the options variants start from.
Variant descriptorVariant(const std::string& name, const Arguments& arguments,
                          const DescriptorOptions& base = {});

/// Images a learned descriptor may train on. count 0: none allowed (the evaluation images are
/// used only with --train-on-eval).
struct Training {
  size_t count = 0;
  eval::ImageLoader load;
  std::string source;  ///< Written into the results: where the training images came from.
};

/// Whether the variant learns from images before it can describe (no model or whitening file).
bool needsTraining(const Variant& variant);

/// cnn_pca without a whitening file and broad without a model learn from `training` first (no
/// labels); the result is written into the output folder and used like a user's file. Throws
/// std::invalid_argument when training is needed but no images are allowed.
void trainWhereNeeded(Variant* variant, const std::string& name, const Training& training,
                      const std::string& output_folder);

/// The extractor of a variant, trained and whitened where it asks for it.
std::shared_ptr<const DescriptorExtractor> makeVariantExtractor(Variant* variant,
                                                                const std::string& name,
                                                                const Training& training,
                                                                const std::string& output_folder);

}  // namespace tools
}  // namespace landmark_loop_closure
