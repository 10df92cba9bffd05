// Regression guard on real data: small, fast subsets evaluated exactly as lcd_evaluate does. The
// floors sit just under the values measured when they were set (bench/README.md has the full
// runs); a change that lowers a measure below its floor fails here. Skips without ../shared.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "landmark_loop_closure/eval/evaluator.h"
#include "landmark_loop_closure/sim/sequence.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::eval;
namespace fs = std::filesystem;

namespace {

const fs::path kData = fs::path(PACKAGE_SOURCE_DIR) / ".." / "shared" / "data";

struct Floor {
  const char* descriptor;
  double recall_at_100_precision;
  double auc;
  double recall_at_1;
};

std::shared_ptr<const DescriptorExtractor> extractor(const std::string& type) {
  DescriptorOptions options;
  options.type = type;
  return makeDescriptorExtractor(options);
}

void expectAtLeast(const Evaluation& e, const Floor& floor) {
  SCOPED_TRACE(floor.descriptor);
  const Metrics& m = e.metrics;
  std::cout << floor.descriptor << ": R@100P " << m.recall_at_100_precision << ", AUC " << m.auc
            << ", R@1 " << m.recall_at_1 << "\n";
  EXPECT_GE(m.recall_at_100_precision, floor.recall_at_100_precision);
  EXPECT_GE(m.auc, floor.auc);
  EXPECT_GE(m.recall_at_1, floor.recall_at_1);
}

void checkTraversals(const fs::path& database_folder, const fs::path& query_folder, size_t limit,
                     int tolerance, const std::vector<Floor>& floors) {
  if (!fs::exists(database_folder)) GTEST_SKIP() << database_folder << " is absent";
  std::vector<std::string> database = listImages(database_folder.string());
  std::vector<std::string> queries = listImages(query_folder.string());
  if (database.size() > limit) database.resize(limit);
  if (queries.size() > limit) queries.resize(limit);
  const GroundTruth truth = alignedGroundTruth(queries.size(), database.size(), tolerance);
  for (const Floor& floor : floors) {
    const auto describe = extractor(floor.descriptor);
    const Evaluation e = evaluateTraversals(describeImageFiles(database, *describe),
                                            describeImageFiles(queries, *describe), truth,
                                            *describe, MatchingOptions{});
    expectAtLeast(e, floor);
  }
}

}  // namespace

TEST(BaselineRegression, NordlandWinterAgainstSummerFirst300) {
  // Measured: pixels 0.007 / 0.090 / 0.247, hog 0.020 / 0.156 / 0.317,
  // hog_whole 0.007 / 0.413 / 0.563 (R@100P / AUC / R@1, +-2 frames), backbone (the default:
  // HOG alone at 64x32) 0.037 / 0.441 / 0.553.
  checkTraversals(kData / "nordland" / "summer", kData / "nordland" / "winter", 300, 2,
                  {{"backbone", 0.025, 0.42, 0.53},
                   {"pixels", 0.005, 0.08, 0.23},
                   {"hog", 0.015, 0.14, 0.30},
                   {"hog_whole", 0.005, 0.39, 0.54}});
}

TEST(BaselineRegression, GardensPointDayRightAgainstDayLeft) {
  // Measured: pixels 0.080 / 0.394 / 0.510, hog 0.010 / 0.204 / 0.320,
  // hog_whole 0.070 / 0.192 / 0.330, landmarks (shipped encoder, HOG patches) 0.040 / 0.603 /
  // 0.680, backbone (the default, pretrained network) 0.570 / 0.895 / 0.910 (+-3).
  checkTraversals(kData / "gardens_point" / "day_left", kData / "gardens_point" / "day_right", 100,
                  3,
                  {{"pixels", 0.07, 0.37, 0.49},
                   {"hog", 0.005, 0.19, 0.30},
                   {"hog_whole", 0.06, 0.18, 0.31},
                   {"landmarks", 0.03, 0.58, 0.66},
                   {"backbone", 0.50, 0.87, 0.88}});
}

TEST(BaselineRegression, GardensPointNightRightAgainstDayRight) {
  // Appearance change. Measured: hog_whole 0.150 / 0.545 / 0.640, landmarks 0.060 / 0.174 /
  // 0.330 (conv2 crops instead of HOG patches: 0.010 / 0.077 / 0.220), backbone 0.800 / 0.945 /
  // 0.950.
  checkTraversals(kData / "gardens_point" / "day_right", kData / "gardens_point" / "night_right",
                  100, 3,
                  {{"hog_whole", 0.14, 0.52, 0.62},
                   {"landmarks", 0.04, 0.16, 0.31},
                   {"backbone", 0.70, 0.92, 0.93}});
}

TEST(BaselineRegression, GeneratedCorridorSequence) {
  // Generated, so it needs no data: two laps, an image every 0.3 m, poses as ground truth.
  // Measured: pixels 0.549 / 0.949 / 0.963, hog 0.221 / 0.581 / 0.766.
  const sim::SampledSequence corridor =
      sim::sampleSequence(sim::CorridorWorld{}, sim::SequenceOptions{}, 3);
  const std::vector<cv::Mat>& images = corridor.images;
  const GroundTruth truth =
      poseGroundTruth(corridor.truth, corridor.stamps, 2.5, 45.0 * M_PI / 180.0, 20.0);
  MatchingOptions options;
  options.exclude_recent = 60;
  for (const Floor& floor : {Floor{"pixels", 0.52, 0.92, 0.94}, Floor{"hog", 0.20, 0.55, 0.74}}) {
    const auto describe = extractor(floor.descriptor);
    const DescribedImages described = describeImages(
        images.size(), [&images](size_t i) { return images[i]; }, *describe);
    expectAtLeast(evaluateSequence(described, truth, *describe, options), floor);
  }
}
