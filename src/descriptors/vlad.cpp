#include "landmark_loop_closure/descriptors/vlad.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <utility>

#include "common/checksummed_file.h"
#include "landmark_loop_closure/common/image_helpers.h"

namespace landmark_loop_closure {

namespace {

constexpr char kVocabularyMagic[8] = {'L', 'L', 'C', 'V', 'L', 'A', 'D', 'V'};
constexpr uint32_t kVocabularyVersion = 1;
constexpr uint32_t kMaxClusters = 4096;
constexpr uint32_t kVocabularyMaxDimension = 8192;

}  // namespace

VladVocabulary::VladVocabulary(cv::Mat centres, std::string identity)
    : identity_(std::move(identity)) {
  if (centres.empty() || centres.type() != CV_32F || !cv::checkRange(centres)) {
    throw std::invalid_argument("a VLAD vocabulary needs finite float centres");
  }
  centres_ = centres.clone();
}

VladVocabulary VladVocabulary::learn(const cv::Mat& samples, int clusters,
                                     const std::string& identity, uint64_t seed) {
  if (clusters < 1) throw std::invalid_argument("a vocabulary needs at least one cluster");
  if (samples.type() != CV_32F || samples.rows < clusters) {
    throw std::invalid_argument("k-means of " + std::to_string(clusters) +
                                " clusters needs at least as many float samples, got " +
                                std::to_string(samples.rows));
  }
  cv::RNG& rng = cv::theRNG();
  const uint64_t saved_state = rng.state;
  rng.state = seed;  // k-means++ draws from OpenCV's generator: seed it for a repeatable result.
  cv::Mat labels;
  cv::Mat centres;
  cv::kmeans(samples, clusters, labels,
             cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-4), 1,
             cv::KMEANS_PP_CENTERS, centres);
  rng.state = saved_state;
  return VladVocabulary(centres, identity);
}

void VladVocabulary::save(const std::string& path) const {
  LittleEndianWriter writer;
  beginChecksummedFile(&writer, kVocabularyMagic, kVocabularyVersion);
  writer.u32(static_cast<uint32_t>(clusters()));
  writer.u32(static_cast<uint32_t>(dimension()));
  writer.text(identity_);
  const cv::Mat rows = centres_.isContinuous() ? centres_ : centres_.clone();
  writer.floats(rows.ptr<float>(), rows.total());
  const std::string error = finishChecksummedFile(path, &writer);
  if (!error.empty()) throw VocabularyFileError("vocabulary file " + path + ": " + error);
}

VladVocabulary VladVocabulary::load(const std::string& path) {
  const auto fail = [&path](const std::string& what) {
    return VocabularyFileError("vocabulary file " + path + ": " + what);
  };
  std::vector<uint8_t> body;
  const std::string error =
      readChecksummedFile(path, kVocabularyMagic, kVocabularyVersion, "vocabulary", &body);
  if (!error.empty()) throw fail(error);
  LittleEndianReader reader(body.data(), body.size());
  uint32_t clusters = 0, dimension = 0;
  std::string identity;
  const bool header = reader.u32(&clusters) && reader.u32(&dimension) && clusters > 0 &&
                      dimension > 0 && clusters <= kMaxClusters &&
                      dimension <= kVocabularyMaxDimension && reader.text(&identity);
  if (!header) throw fail("header is damaged");
  cv::Mat centres(static_cast<int>(clusters), static_cast<int>(dimension), CV_32F);
  if (!reader.floats(centres.ptr<float>(), centres.total()) || reader.remaining() != 0) {
    throw fail("size does not match its header");
  }
  if (!cv::checkRange(centres)) throw fail("holds NaN or infinity");
  return VladVocabulary(centres, identity);
}

cv::Mat localFeatures(const FeatureMaps& maps, bool unit) {
  if (maps.empty()) return cv::Mat(0, maps.channels, CV_32F);
  const int cells = maps.height * maps.width;
  cv::Mat features(cells, maps.channels, CV_32F);
  for (int c = 0; c < maps.channels; ++c) {
    const float* channel = maps.channel(c);
    for (int k = 0; k < cells; ++k) features.at<float>(k, c) = channel[k];
  }
  if (!unit) return features;
  for (int k = 0; k < cells; ++k) {
    normaliseL2(features.ptr<float>(k), features.ptr<float>(k) + maps.channels);
  }
  return features;
}

std::vector<float> vladAggregate(const cv::Mat& features, const VladVocabulary& vocabulary,
                                 const VladOptions& options) {
  const int clusters = vocabulary.clusters();
  const int dimension = vocabulary.dimension();
  std::vector<float> vlad(static_cast<size_t>(clusters) * dimension, 0.0f);
  if (features.empty()) return vlad;
  if (features.type() != CV_32F || features.cols != dimension) {
    throw std::invalid_argument("VLAD: features of " + std::to_string(features.cols) +
                                " values against a vocabulary of " + std::to_string(dimension));
  }
  const cv::Mat& centres = vocabulary.centres();
  const int assignments = std::max(1, std::min(options.assignments, clusters));
  std::vector<float> distances(static_cast<size_t>(clusters));
  std::vector<int> order(static_cast<size_t>(clusters));
  std::vector<float> weights(static_cast<size_t>(assignments));
  for (int row = 0; row < features.rows; ++row) {
    const float* feature = features.ptr<float>(row);
    for (int k = 0; k < clusters; ++k) {
      const float* centre = centres.ptr<float>(k);
      float distance = 0.0f;
      for (int d = 0; d < dimension; ++d) {
        const float difference = feature[d] - centre[d];
        distance += difference * difference;
      }
      distances[static_cast<size_t>(k)] = distance;
    }
    std::iota(order.begin(), order.end(), 0);
    std::partial_sort(order.begin(), order.begin() + assignments, order.end(),
                      [&distances](int a, int b) { return distances[a] < distances[b]; });
    float total = 0.0f;
    for (int j = 0; j < assignments; ++j) {
      const float excess = distances[order[j]] - distances[order[0]];
      weights[j] = static_cast<float>(std::exp(-options.sharpness * excess));
      total += weights[j];
    }
    for (int j = 0; j < assignments; ++j) {
      const float weight = weights[j] / total;
      const float* centre = centres.ptr<float>(order[j]);
      float* sum = vlad.data() + static_cast<size_t>(order[j]) * dimension;
      for (int d = 0; d < dimension; ++d) sum[d] += weight * (feature[d] - centre[d]);
    }
  }
  for (float& value : vlad) value = std::copysign(std::sqrt(std::fabs(value)), value);
  for (int k = 0; k < clusters; ++k) {  // Intra-normalisation: each centre's sum alike.
    normaliseL2(vlad.data() + static_cast<size_t>(k) * dimension,
                vlad.data() + static_cast<size_t>(k + 1) * dimension);
  }
  normaliseL2(&vlad);
  return vlad;
}

}  // namespace landmark_loop_closure
