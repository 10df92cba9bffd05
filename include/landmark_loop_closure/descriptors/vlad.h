#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/descriptors/landmarks.h"

namespace landmark_loop_closure {

/// A vocabulary file that cannot be used: missing, truncated, corrupt, or made for other features.
class VocabularyFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The cluster centres VLAD assigns a network's local features to, learnt without labels by
/// k-means on unlabelled images of the domain (AnyLoc's recipe; `lcd_train vocabulary`).
class VladVocabulary {
 public:
  /// k-means++ on `samples` (one unit local feature per row, N x D, CV_32F), `clusters` centres,
  /// deterministic for a seed; `identity` says which features the samples are (model, layer,
  /// input). Throws std::invalid_argument for fewer samples than clusters.
  static VladVocabulary learn(const cv::Mat& samples, int clusters, const std::string& identity,
                              uint64_t seed = 1);
  /// From centres given directly; K x D, CV_32F, finite.
  VladVocabulary(cv::Mat centres, std::string identity);
  VladVocabulary() = default;

  int clusters() const { return centres_.rows; }
  int dimension() const { return centres_.cols; }
  bool empty() const { return centres_.empty(); }
  const cv::Mat& centres() const { return centres_; }
  const std::string& identity() const { return identity_; }

  /// Little-endian binary file with a checksum and the identity, written atomically.
  void save(const std::string& path) const;
  /// Throws VocabularyFileError naming the file and what is wrong.
  static VladVocabulary load(const std::string& path);

 private:
  cv::Mat centres_;
  std::string identity_;
};

/// How local features are aggregated against a vocabulary.
struct VladOptions {
  /// Nearest centres each local feature is shared between: 1 = hard assignment; more = soft, with
  /// weights exp(-sharpness * (d^2 - d_nearest^2)) over those centres.
  int assignments = 1;
  double sharpness = 10.0;
  /// Local features L2-normalised before assignment (every cell counts alike); false: raw, so
  /// weak (dark) cells add small residuals.
  bool unit_features = true;
};

/// The maps' local features (one per map cell), each L2-normalised when `unit`:
/// (height * width) x channels, CV_32F. Cells whose feature is all zero stay zero.
cv::Mat localFeatures(const FeatureMaps& maps, bool unit = true);

/// VLAD (Jegou et al.): per centre, the sum of the residuals of the features assigned to it;
/// each residual sum signed-square-rooted (power law) and L2-normalised (intra-normalisation),
/// then the whole vector L2-normalised. clusters * dimension values; all zero when `features`
/// is empty. Throws std::invalid_argument when the feature and centre dimensions differ.
std::vector<float> vladAggregate(const cv::Mat& features, const VladVocabulary& vocabulary,
                                 const VladOptions& options = {});

}  // namespace landmark_loop_closure
