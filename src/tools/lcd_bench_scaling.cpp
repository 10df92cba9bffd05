// Scaling benchmark: query time and memory of the keyframe database as it grows, with synthetic
// descriptors (random unit vectors of the real descriptors' lengths). One thread.
//   lcd_bench_scaling [sizes=1000,10000,100000] [queries=200]
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/eval/metrics.h"
#include "landmark_loop_closure/eval/report.h"
#include "landmark_loop_closure/hog_descriptor.h"
#include "landmark_loop_closure/keyframe_database.h"

namespace {

using namespace landmark_loop_closure;

std::vector<float> randomUnitVector(int dimension, std::mt19937* random) {
  std::normal_distribution<float> normal;
  std::vector<float> values(static_cast<size_t>(dimension));
  for (float& v : values) v = normal(*random);
  normaliseL2(&values);
  return values;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<size_t> sizes = {1000, 10000, 100000};
  if (argc > 1) {
    sizes.clear();
    std::istringstream list(argv[1]);
    std::string item;
    while (std::getline(list, item, ',')) sizes.push_back(std::stoul(item));
  }
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
        KeyframeRecord keyframe;
        keyframe.id = id;
        keyframe.stamp = static_cast<double>(id);
        keyframe.descriptor.global = randomUnitVector(dimension, &random);
        database.add(std::move(keyframe));
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
