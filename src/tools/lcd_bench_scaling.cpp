// Scaling benchmark: query time, shortlist recall and memory of the keyframe database as it
// grows, one thread. Keyframes are realistic in size (one described corridor keyframe's landmarks,
// keypoints with depths and thumbnail, copied with their own buffers) with synthetic global
// descriptors: a route through descriptor space (each keyframe a small random step from the last,
// cosine ~0.9, as neighbouring keyframes of a sequence are). Each query revisits a random stored
// keyframe (cosine ~0.9 to it). Exact search and the HNSW graph at several ef_search values are
// timed with the landmark re-ranking of the top_k, and the graph's top_k is compared with exact's.
//   lcd_bench_scaling [sizes=1000,10000,100000] [queries=200] [--descriptor landmarks|hog|both]
// The map on disk (insert, reopening, file size) is lcd_bench_map's.

#include <chrono>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "bench_workload.h"
#include "command_line.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/descriptors/hog_descriptor.h"
#include "landmark_loop_closure/eval/metrics.h"
#include "landmark_loop_closure/eval/report.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/sim/corridor_world.h"

namespace {

using namespace landmark_loop_closure;
using bench::Route;

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// One keyframe as the node stores it with the shipped settings (landmarks descriptor).
KeyframeRecord realisticKeyframe(const DescriptorExtractor& extractor) {
  return bench::describedKeyframe(extractor, bench::corridorView());
}

struct Workload {
  std::string name;
  int dimension = 0;
  std::shared_ptr<const DescriptorExtractor> extractor;
  KeyframeRecord model;  ///< What every keyframe carries besides its global vector.
};

Workload landmarksWorkload() {
  Workload workload;
  workload.extractor = makeDescriptorExtractor(DescriptorOptions{});
  workload.model = realisticKeyframe(*workload.extractor);
  workload.dimension = static_cast<int>(workload.model.descriptor.global.size());
  workload.name = workload.extractor->name() + " (shipped)";
  return workload;
}

Workload hogWorkload() {
  Workload workload;
  DescriptorOptions options;
  options.type = "hog";
  workload.extractor = makeDescriptorExtractor(options);
  workload.dimension = HogDescriptor::kDimension;
  workload.name = "hog, global only";
  return workload;
}

KeyframeDatabase buildDatabase(const Workload& workload, size_t size, Route* route,
                               double* insert_ms) {
  KeyframeDatabase database(workload.dimension, IndexOptions{});
  const KeyframeRecord& model = workload.model;
  const auto start = Clock::now();
  for (size_t id = 0; id < size; ++id) {
    KeyframeRecord keyframe;
    keyframe.id = id;
    keyframe.stamp = static_cast<double>(id);
    keyframe.descriptor.global = route->next();
    keyframe.descriptor.landmark_boxes = model.descriptor.landmark_boxes;
    keyframe.descriptor.landmark_features = model.descriptor.landmark_features.clone();
    keyframe.local_features = model.local_features;
    keyframe.local_features.descriptors = model.local_features.descriptors.clone();
    keyframe.thumbnail = model.thumbnail;
    database.add(std::move(keyframe));
  }
  if (insert_ms) *insert_ms = msSince(start) / static_cast<double>(size);
  return database;
}

struct SearchRow {
  std::string search;
  int ef_search = 0;  ///< 0: exact search.
  std::vector<double> query_ms;
  std::vector<double> total_ms;  ///< Query and re-ranking of the top_k.
  int shared_with_exact = 0;     ///< Top-k ids the exact search also returned.
  int revisits_found = 0;        ///< Queries whose revisited keyframe is in the top_k.
};

int runQueries(const std::vector<size_t>& sizes, int queries, const std::vector<Workload>& loads) {
  std::printf(
      "| descriptor | keyframes | search | query median (ms) | query p99 (ms) | + re-rank median "
      "(ms) | + re-rank p99 (ms) | top-10 shared with exact | revisit in top-10 | insert (ms) | "
      "bytes per keyframe | peak RSS (MB) |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Workload& workload : loads) {
    for (const size_t size : sizes) {
      Route route(workload.dimension, 42);
      double insert_ms = 0.0;
      const KeyframeDatabase database = buildDatabase(workload, size, &route, &insert_ms);
      DatabaseOptions options;  // Shipped exclusions and top_k.
      std::vector<SearchRow> rows;
      for (const int ef : {0, 64, 128, 256}) {
        SearchRow row;
        row.search = ef == 0 ? "exact" : "hnsw ef_search " + std::to_string(ef);
        row.ef_search = ef;
        rows.push_back(row);
      }
      std::uniform_int_distribution<size_t> pick(0, size - 100);
      for (int q = 0; q < queries; ++q) {
        const size_t place = pick(route.random());
        ImageDescriptor query = workload.model.descriptor;
        query.global = route.revisit(database.record(place)->descriptor.global);
        const double stamp = static_cast<double>(size) + 100.0;
        std::set<uint64_t> exact_ids;
        for (size_t r = 0; r < rows.size(); ++r) {
          DatabaseOptions search = options;
          search.index.type = rows[r].ef_search == 0 ? "exact" : "approximate";
          search.index.ef_search = std::max(1, rows[r].ef_search);
          const auto start = Clock::now();
          const QueryResult result = database.query(query.global, stamp, search);
          rows[r].query_ms.push_back(msSince(start));
          if (workload.extractor->reranks()) {
            for (const Candidate& candidate : result.candidates) {
              workload.extractor->similarity(query, database.record(candidate.index)->descriptor);
            }
          }
          rows[r].total_ms.push_back(msSince(start));
          for (const Candidate& candidate : result.candidates) {
            if (r == 0) exact_ids.insert(candidate.id);
            rows[r].shared_with_exact += static_cast<int>(exact_ids.count(candidate.id));
            rows[r].revisits_found += candidate.id == place;
          }
        }
      }
      for (const SearchRow& row : rows) {
        const eval::Percentiles query = eval::percentiles(row.query_ms);
        const eval::Percentiles total = eval::percentiles(row.total_ms);
        std::printf(
            "| %s (%d values) | %zu | %s | %.2f | %.2f | %.2f | %.2f | %.3f | %.3f | %.2f | %.0f | "
            "%.0f |\n",
            workload.name.c_str(), workload.dimension, size, row.search.c_str(), query.median,
            query.p99, total.median, total.p99, row.shared_with_exact / (10.0 * queries),
            row.revisits_found / double(queries), insert_ms,
            static_cast<double>(database.bytes()) / size, eval::peakResidentBytes() / 1e6);
      }
      std::fflush(stdout);
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<size_t> sizes = {1000, 10000, 100000};
  std::string descriptor = "both";
  int queries = 200;
  CLI::App app{"Search time and memory of the keyframe database as it grows."};
  app.add_option("sizes", sizes, "database sizes, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("queries", queries, "timed queries at each size")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--descriptor", descriptor, "landmarks, hog or both")
      ->check(CLI::IsMember({"landmarks", "hog", "both"}))
      ->capture_default_str();
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  cv::setNumThreads(1);
  std::vector<Workload> loads;
  if (descriptor != "hog") loads.push_back(landmarksWorkload());
  if (descriptor != "landmarks") loads.push_back(hogWorkload());
  return runQueries(sizes, queries, loads);
}
