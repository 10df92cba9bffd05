// Scaling benchmark: query time and memory of the keyframe database as it grows, with synthetic
// descriptors (random unit vectors of the real descriptors' lengths). One thread.
//   lcd_bench_scaling [sizes=1000,10000,100000] [queries=200]
// With --persistence: save and load time and file size of databases of realistic keyframes (one
// described corridor keyframe - landmarks, keypoints with depths, thumbnail - copied with its own
// buffers and a random global vector), written to --folder (default /tmp).
//   lcd_bench_scaling --persistence [sizes=1000,10000,100000] [--folder /tmp]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "landmark_loop_closure/database_file.h"
#include "landmark_loop_closure/descriptor.h"
#include "landmark_loop_closure/eval/metrics.h"
#include "landmark_loop_closure/eval/report.h"
#include "landmark_loop_closure/geometric_verification.h"
#include "landmark_loop_closure/hog_descriptor.h"
#include "landmark_loop_closure/keyframe_database.h"
#include "landmark_loop_closure/sim/corridor_world.h"

namespace {

using namespace landmark_loop_closure;

std::vector<float> randomUnitVector(int dimension, std::mt19937* random) {
  std::normal_distribution<float> normal;
  std::vector<float> values(static_cast<size_t>(dimension));
  for (float& v : values) v = normal(*random);
  normaliseL2(&values);
  return values;
}

// A keyframe with only an id, a stamp and a random global descriptor.
KeyframeRecord syntheticKeyframe(size_t id, int dimension, std::mt19937* random) {
  KeyframeRecord keyframe;
  keyframe.id = id;
  keyframe.stamp = static_cast<double>(id);
  keyframe.descriptor.global = randomUnitVector(dimension, random);
  return keyframe;
}

std::vector<size_t> parseSizes(const std::string& text) {
  std::vector<size_t> sizes;
  std::istringstream list(text);
  std::string item;
  while (std::getline(list, item, ',')) sizes.push_back(std::stoul(item));
  return sizes;
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// One keyframe as the node stores it with the shipped settings.
KeyframeRecord realisticKeyframe() {
  const sim::CorridorWorld world;
  const cv::Mat image =
      world.render(world.poseAt(5.0, 0.0), sim::CameraModel{}, sim::Lighting{}, 1);
  KeyframeRecord keyframe;
  keyframe.descriptor = makeDescriptorExtractor(DescriptorOptions{})->describe(image);
  keyframe.local_features = GeometricVerifier(VerificationOptions{}).extract(image);
  const size_t points = keyframe.local_features.points.size();
  keyframe.local_features.points3d.assign(points, cv::Point3f(0.5f, -0.2f, 4.0f));
  keyframe.local_features.depth_sd.assign(points, 0.05f);
  cv::Mat thumbnail;
  cv::resize(image, thumbnail, cv::Size(160, 120));
  keyframe.thumbnail_jpeg = encodeThumbnail(thumbnail);
  return keyframe;
}

int runPersistence(const std::vector<size_t>& sizes, const std::string& folder) {
  const KeyframeRecord model = realisticKeyframe();
  const int dimension = static_cast<int>(model.descriptor.global.size());
  std::printf(
      "| keyframes | bytes per keyframe (memory) | file MB | save (s) | load (s) | load per 1000 "
      "(ms) |\n|---|---|---|---|---|---|\n");
  for (const size_t size : sizes) {
    std::mt19937 random(7);
    KeyframeDatabase database(dimension);
    for (size_t id = 0; id < size; ++id) {
      KeyframeRecord keyframe = syntheticKeyframe(id, dimension, &random);
      keyframe.descriptor.landmark_boxes = model.descriptor.landmark_boxes;
      keyframe.descriptor.landmark_features = model.descriptor.landmark_features.clone();
      keyframe.local_features = model.local_features;
      keyframe.local_features.descriptors = model.local_features.descriptors.clone();
      keyframe.thumbnail_jpeg = model.thumbnail_jpeg;
      database.add(std::move(keyframe));
    }
    const std::string path = folder + "/lcd_bench_scaling.lcdb";
    auto start = std::chrono::steady_clock::now();
    const std::string error = saveDatabase(database, "bench", path);
    const double save_s = secondsSince(start);
    if (!error.empty()) {
      std::fprintf(stderr, "%s\n", error.c_str());
      return 1;
    }
    start = std::chrono::steady_clock::now();
    const LoadedDatabase loaded = loadDatabase(path, "bench", dimension);
    const double load_s = secondsSince(start);
    if (!loaded.database || loaded.database->size() != size) {
      std::fprintf(stderr, "%s\n", loaded.error.c_str());
      return 1;
    }
    std::printf("| %zu | %.0f | %.0f | %.2f | %.2f | %.1f |\n", size,
                static_cast<double>(database.bytes()) / size,
                static_cast<double>(std::filesystem::file_size(path)) / 1e6, save_s, load_s,
                1000.0 * load_s / size * 1000.0);
    std::fflush(stdout);
    std::filesystem::remove(path);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "--persistence") {
    std::vector<size_t> persistence_sizes = {1000, 10000, 100000};
    std::string folder = "/tmp";
    for (int i = 2; i < argc; ++i) {
      if (std::string(argv[i]) == "--folder" && i + 1 < argc) {
        folder = argv[++i];
      } else {
        persistence_sizes = parseSizes(argv[i]);
      }
    }
    cv::setNumThreads(1);
    return runPersistence(persistence_sizes, folder);
  }
  std::vector<size_t> sizes = {1000, 10000, 100000};
  if (argc > 1) sizes = parseSizes(argv[1]);
  const int queries = argc > 2 ? std::atoi(argv[2]) : 200;
  cv::setNumThreads(1);
  std::printf(
      "| descriptor | keyframes | query median (ms) | query p99 (ms) | bytes per keyframe |"
      " peak RSS (MB) |\n|---|---|---|---|---|---|\n");
  for (const auto& [name, dimension] :
       {std::pair<const char*, int>{"hog", HogDescriptor::kDimension}}) {
    for (const size_t size : sizes) {
      std::mt19937 random(42);
      KeyframeDatabase database(dimension);
      for (size_t id = 0; id < size; ++id) {
        database.add(syntheticKeyframe(id, dimension, &random));
      }
      DatabaseOptions options;
      options.min_size = 1;
      options.exclude_recent_keyframes = 0;
      options.exclude_recent_seconds = 0.0;
      std::vector<double> times;
      for (int q = 0; q < queries; ++q) {
        const std::vector<float> query = randomUnitVector(dimension, &random);
        const auto start = std::chrono::steady_clock::now();
        const QueryResult result = database.query(query, 1e12, options);
        times.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                .count());
        if (result.candidates.empty()) return 1;
      }
      const eval::Percentiles p = eval::percentiles(times);
      std::printf("| %s (%d values) | %zu | %.2f | %.2f | %.0f | %.0f |\n", name, dimension, size,
                  p.median, p.p99, static_cast<double>(database.bytes()) / size,
                  eval::peakResidentBytes() / 1e6);
      std::fflush(stdout);
    }
  }
  return 0;
}
