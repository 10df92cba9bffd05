// lcd_bench_map: the node's map at scale, as the node keeps it - every keyframe committed to the
// map file (KeyframeStore) and added to search (KeyframeDatabase reading records from the file).
// Keyframes are described keyframes of the --image list used in turn, or a corridor view (the
// shipped descriptor, ORB keypoints with depths, thumbnail), with synthetic global vectors along
// a route (each a small step from the last); each query revisits a random stored keyframe. At each
// checkpoint it prints insert time per keyframe, RAM (the database's bytes and the process's
// resident set), file bytes per keyframe, query + re-rank time (graph search, then the top_k
// records read from the file) and the graph's recall of exact search's top_k. Then it saves the
// graph, closes, reopens the map as the node does (summaries, vectors and the saved graph; records
// stay on disk) and queries again. With --reopen it builds nothing: it reopens the map an earlier
// run left in --dir and measures query + re-rank and recall at each --ef value (ef_search; default
// the shipped one). Reopening times the first queries (--first-queries) while the sealed search
// rows are checked on their own thread, as the node starts, and when that check ends. Both modes
// end by saving the graph and search rows as a node's shutdown does.
// --route picks the synthetic vectors: "measured" (default; spread like the shipped descriptor's of
// real images) or "isotropic" (the worst case for a graph); --measure-route DIR,DIR prints how real
// images' vectors spread next to both routes, and stops.
//   lcd_bench_map [--keyframes 1000000] [--checkpoints 10000,100000,1000000] [--queries 300]
//                 [--recall-queries 50] [--dir /tmp/lcd_bench_map] [--image a.jpg,b.jpg]
//                 [--reopen] [--ef 256,512] [--first-queries 20] [--ef-construction 64]
//                 [--neighbors 16]
//                 [--route measured|isotropic] [--measure-route DIR,DIR]
//                 [--identity bench|detector]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bench_workload.h"
#include "command_line.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/database/quantized_vectors.h"
#include "landmark_loop_closure/descriptors/registry.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/sim/corridor_world.h"
#include "route_measurement.h"

namespace {

using namespace landmark_loop_closure;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using bench::Route;

double msSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1, static_cast<size_t>(p * (values.size() - 1) + 0.5))];
}

double residentMegabytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return 0.0;
}

struct Settings {
  size_t keyframes = 1000000;
  std::vector<size_t> checkpoints = {10000, 100000, 1000000};
  int queries = 300;
  int recall_queries = 50;
  fs::path dir = "/tmp/lcd_bench_map";
  /// The model keyframes' images, comma-separated, used in turn (records of real size vary, and
  /// SQLite's pages fit one repeated size better or worse than the average); "" = a generated
  /// corridor view.
  std::string image;
  bool reopen_only = false;
  IndexOptions index;  ///< The shipped graph settings unless --ef-construction / --neighbors.
  std::vector<int> ef_search = {IndexOptions().ef_search};
  int first_queries = 20;          ///< Timed one by one straight after reopening.
  bool detector_identity = false;  ///< --identity detector: a map the node can open.
  bench::RouteShape route = bench::RouteShape::kMeasured;
};

// The shipped descriptor, or the one the node falls back to without the fetched backbone.
std::shared_ptr<const DescriptorExtractor> shippedExtractor() {
  try {
    return makeDescriptorExtractor(DescriptorOptions{});
  } catch (const std::exception&) {
    DescriptorOptions landmarks;
    landmarks.type = "landmarks";
    return makeDescriptorExtractor(landmarks);
  }
}

// Keyframes as the node stores them with the shipped settings and a depth camera, one per image of
// the comma-separated `image_paths` (real camera images: more keypoints, larger thumbnails), or one
// generated corridor view.
std::vector<KeyframeRecord> modelKeyframes(const std::string& image_paths,
                                           std::string* descriptor_name) {
  const std::shared_ptr<const DescriptorExtractor> extractor = shippedExtractor();
  *descriptor_name =
      extractor->name() + " (" + std::to_string(extractor->globalDimension()) + " values)";
  std::vector<KeyframeRecord> models;
  std::stringstream paths(image_paths);
  std::string path;
  while (std::getline(paths, path, ',')) {
    const cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (image.empty()) throw std::runtime_error("cannot read the image " + path);
    models.push_back(bench::describedKeyframe(*extractor, image));
  }
  if (models.empty()) models.push_back(bench::describedKeyframe(*extractor, bench::corridorView()));
  return models;
}

void attachReader(KeyframeDatabase* database, const KeyframeStore* store) {
  database->readRecordsFrom([store](uint64_t id) { return store->get(id); }, 64);
}

// Every this many keyframes one is kept as a place to revisit (keyframe id = row = index * this).
constexpr size_t kPlaceEvery = 997;

struct QueryFigures {
  std::vector<double> total_ms;
  double recall = 0.0;
  double revisit_found = 0.0;  ///< Share of queries whose revisited keyframe is in the top_k.
};

QueryFigures runQueries(const KeyframeDatabase& database, Route* route, const Settings& settings,
                        const std::vector<std::vector<float>>& places,
                        int ef_search = IndexOptions().ef_search) {
  QueryFigures figures;
  DatabaseOptions search;
  search.index.type = "approximate";
  search.index.ef_search = ef_search;
  DatabaseOptions exact = search;
  exact.index.type = "exact";
  std::uniform_int_distribution<size_t> pick(0, places.size() - 1);
  size_t shared = 0;
  size_t compared = 0;
  size_t revisits_found = 0;
  const double stamp = 1e12;  // After every keyframe: nothing excluded.
  for (int q = 0; q < settings.queries; ++q) {
    const size_t place = pick(route->random());
    const std::vector<float> query = route->revisit(places[place]);
    const auto start = Clock::now();
    const QueryResult found = database.query(query, stamp, search, 1000);
    size_t read = 0;
    for (const Candidate& candidate : found.candidates) {
      read += database.record(candidate.index) != nullptr;
      revisits_found += candidate.id == place * kPlaceEvery;
    }
    figures.total_ms.push_back(msSince(start));
    if (read != found.candidates.size()) std::cerr << "a record could not be read\n";
    if (q < settings.recall_queries) {
      std::set<uint64_t> exact_ids;
      for (const Candidate& c : database.query(query, stamp, exact, 1000).candidates) {
        exact_ids.insert(c.id);
      }
      for (const Candidate& c : found.candidates) shared += exact_ids.count(c.id);
      compared += exact_ids.size();
    }
  }
  figures.recall = compared > 0 ? static_cast<double>(shared) / compared : 0.0;
  figures.revisit_found = static_cast<double>(revisits_found) / std::max(1, settings.queries);
  return figures;
}

// Builds the map at `path` keyframe by keyframe as the node does, printing each checkpoint, then
// saves the graph beside it.
void buildMap(const Settings& settings, const std::string& path, const std::string& identity,
              const IndexOptions& index, std::optional<Route>* route,
              std::vector<std::vector<float>>* places) {
  std::string descriptor;
  const std::vector<KeyframeRecord> models = modelKeyframes(settings.image, &descriptor);
  const int dimension = static_cast<int>(models.front().descriptor.global.size());
  std::cout << "Map of " << descriptor << " keyframes, in turn from " << models.size()
            << " model keyframes:\n";
  for (const KeyframeRecord& model : models) {
    std::cout << "  " << model.local_features.points.size() << " keypoints and depths, "
              << model.descriptor.landmark_boxes.size() << " landmarks, a "
              << model.thumbnail.size() << "-byte thumbnail\n";
  }

  std::cout
      << "\n| keyframes | insert ms median / p99 | database RAM B/keyframe | process RSS MB | "
         "map B/keyframe (file, log, rows) | query + re-rank ms median / p99 | recall@10 | "
         "revisit in top-10 "
         "|\n|---|---|---|---|---|---|---|---|\n";
  route->emplace(dimension, 7, settings.route);
  auto store = KeyframeStore::open(path, identity, dimension);
  KeyframeDatabase database(dimension, index);
  attachReader(&database, store.get());
  std::vector<double> insert_ms;
  size_t checkpoint = 0;
  for (size_t id = 0; id < settings.keyframes; ++id) {
    KeyframeRecord keyframe = models[id % models.size()];
    keyframe.id = id;
    keyframe.stamp = static_cast<double>(id);
    keyframe.descriptor.global = (*route)->next();
    if (id % kPlaceEvery == 0) places->push_back(keyframe.descriptor.global);
    const auto start = Clock::now();
    store->add(keyframe);
    database.add(std::move(keyframe));
    insert_ms.push_back(msSince(start));
    if (checkpoint < settings.checkpoints.size() && id + 1 == settings.checkpoints[checkpoint]) {
      const QueryFigures queries = runQueries(database, &**route, settings, *places);
      double file_bytes = 0;
      for (const char* part : {"", "-wal", "-vectors"}) {
        if (fs::exists(path + part)) file_bytes += static_cast<double>(fs::file_size(path + part));
      }
      std::printf("| %zu | %.2f / %.2f | %.0f | %.0f | %.0f | %.2f / %.2f | %.3f | %.3f |\n",
                  id + 1, percentile(insert_ms, 0.5), percentile(insert_ms, 0.99),
                  static_cast<double>(database.bytes()) / (id + 1), residentMegabytes(),
                  file_bytes / (id + 1), percentile(queries.total_ms, 0.5),
                  percentile(queries.total_ms, 0.99), queries.recall, queries.revisit_found);
      std::fflush(stdout);
      insert_ms.clear();
      ++checkpoint;
    }
  }
  const auto save_start = Clock::now();
  store->saveGraph(index.graphIdentity(), database);
  std::printf("\nGraph saved in %.2f s (%.0f MB).\n", msSince(save_start) / 1000.0,
              static_cast<double>(fs::file_size(store->graphPath())) / 1e6);
}

}  // namespace

int main(int argc, char** argv) {
  Settings settings;
  std::string dir = settings.dir.string(), identity_name = "bench", route_name = "measured";
  std::vector<std::string> measured_folders;
  CLI::App app{"A map of generated keyframes: insert time, size on disk, reopening, search."};
  app.add_option("--keyframes", settings.keyframes, "keyframes to insert")->capture_default_str();
  app.add_option("--checkpoints", settings.checkpoints, "map sizes at which a line is printed")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--queries", settings.queries, "timed queries at each checkpoint")
      ->capture_default_str();
  app.add_option("--recall-queries", settings.recall_queries,
                 "queries whose top 10 is compared with the exact search's")
      ->capture_default_str();
  app.add_option("--dir", dir, "folder of the map file (bench.map)")->capture_default_str();
  app.add_option("--image", settings.image,
                 "model keyframes' images, comma-separated, used in turn (default: a generated "
                 "corridor view)");
  app.add_flag("--reopen", settings.reopen_only, "reopen the map of an earlier run, insert none");
  app.add_option("--ef", settings.ef_search, "search breadths to measure")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--ef-construction", settings.index.ef_construction, "the graph's build breadth")
      ->capture_default_str();
  app.add_option("--neighbors", settings.index.neighbors, "the graph's neighbours a node")
      ->capture_default_str();
  app.add_option("--first-queries", settings.first_queries,
                 "queries timed one by one straight after reopening")
      ->capture_default_str();
  app.add_option("--route", route_name, "how revisits spread the generated vectors")
      ->check(CLI::IsMember({"measured", "isotropic"}))
      ->capture_default_str();
  app.add_option("--measure-route", measured_folders,
                 "image folders whose descriptors' spread is measured (then exits)")
      ->delimiter(',');
  app.add_option("--identity", identity_name,
                 "the map's descriptor identity: bench, or detector (a map the node can open)")
      ->check(CLI::IsMember({"bench", "detector"}))
      ->capture_default_str();
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  settings.dir = dir;
  settings.detector_identity = identity_name == "detector";
  settings.route =
      route_name == "measured" ? bench::RouteShape::kMeasured : bench::RouteShape::kIsotropic;
  if (!measured_folders.empty()) {
    return bench::measureRoutes(*makeDescriptorExtractor(DescriptorOptions{}), measured_folders);
  }
  fs::create_directories(settings.dir);
  const std::string path = (settings.dir / "bench.map").string();
  const IndexOptions& index = settings.index;
  // "detector": the identity a detector with the shipped settings gives its map, so that the
  // node (and lcd_bench_save) can open it.
  const std::string identity =
      settings.detector_identity
          ? LoopDetector(LoopDetectorOptions{}, shippedExtractor()).descriptorIdentity()
          : "bench";
  std::optional<Route> route;
  std::vector<std::vector<float>> places;  // A sample of stored vectors to revisit.
  if (!settings.reopen_only) {
    for (const char* suffix : {"", "-wal", "-shm", "-graph", "-vectors"}) fs::remove(path + suffix);
    buildMap(settings, path, identity, index, &route, &places);
  } else if (!fs::exists(path)) {
    std::cerr << path << " does not exist: run without --reopen first\n";
    return 1;
  }

  // Reopened as MapSession::open does: the dimension is the descriptor's, the map opened once.
  const int dimension = shippedExtractor()->globalDimension();
  const auto open_start = Clock::now();
  auto store = KeyframeStore::open(path, identity, dimension);
  IndexOptions exact = index;
  exact.type = "exact";
  KeyframeDatabase reopened(dimension, exact);
  store->loadSearch(&reopened);
  attachReader(&reopened, store.get());
  const auto graph_start = Clock::now();
  std::unique_ptr<ApproximateIndex> graph =
      store->loadGraph(index.graphIdentity(), reopened.vectors(), index.neighbors);
  const bool reused = graph != nullptr;
  reopened.setIndex(index, std::move(graph));
  store->startIntegrityCheck();
  const double graph_s = msSince(graph_start) / 1000.0;
  const double open_s = msSince(open_start) / 1000.0;
  std::printf("\nReopened %zu keyframes in %.2f s (graph %s in %.2f s); RSS %.0f MB.\n",
              reopened.size(), open_s, reused ? "read" : "REBUILT", graph_s, residentMegabytes());
  if (!route) route.emplace(dimension, 7, settings.route);
  // Straight after opening, rows and records not yet read (all on disk after a cold start) and the
  // sealed rows' check reading the rows file: what the node's first keyframes meet.
  if (!reopened.empty() && settings.first_queries > 0) {
    std::vector<double> first_ms;
    std::uniform_int_distribution<size_t> pick(0, reopened.size() - 1);
    DatabaseOptions search;
    search.index.type = "approximate";
    for (int q = 0; q < settings.first_queries; ++q) {
      const auto start = Clock::now();
      const std::vector<float> query = route->revisit(
          QuantizedVectors::decode(reopened.vectors()->row(pick(route->random())), dimension));
      for (const Candidate& candidate : reopened.query(query, 1e12, search, 1000).candidates) {
        if (!reopened.record(candidate.index)) std::cerr << "a record could not be read\n";
      }
      first_ms.push_back(msSince(start));
    }
    std::printf("First %d queries + re-rank after opening: %.0f ms median, %.0f ms max.\n",
                settings.first_queries, percentile(first_ms, 0.5), percentile(first_ms, 1.0));
  }
  const KeyframeStore::MapCheck check = store->awaitIntegrityCheck();
  std::printf("Map integrity (sealed search rows, pages) %s %.2f s after opening began.\n",
              check == KeyframeStore::MapCheck::kPassed ? "checked" : "FOUND DAMAGED",
              msSince(open_start) / 1000.0);
  std::fflush(stdout);
  if (places.empty()) {
    for (size_t row = 0; row < reopened.size(); row += kPlaceEvery) {
      places.push_back(QuantizedVectors::decode(reopened.vectors()->row(row), dimension));
    }
  }
  std::printf(
      "\n| ef_search | query + re-rank ms median / p99 | recall@10 | revisit in top-10 |\n"
      "|---|---|---|---|\n");
  for (const int ef : settings.ef_search) {
    const QueryFigures queries = runQueries(reopened, &*route, settings, places, ef);
    std::printf("| %d | %.2f / %.2f | %.3f | %.3f |\n", ef, percentile(queries.total_ms, 0.5),
                percentile(queries.total_ms, 0.99), queries.recall, queries.revisit_found);
    std::fflush(stdout);
  }
  // Closed as a node shuts down: the graph and rows saved for the next open.
  const auto save_start = Clock::now();
  store->saveGraph(index.graphIdentity(), reopened);
  std::printf("\nGraph and search rows saved in %.2f s.\n", msSince(save_start) / 1000.0);
  return 0;
}
