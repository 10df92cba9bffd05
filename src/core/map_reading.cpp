// Reading a map file for search apart from the detector (a load beside the live map).
#include "landmark_loop_closure/core/map_reading.h"

#include "landmark_loop_closure/database/approximate_index.h"

#include <algorithm>
#include <filesystem>
#include <optional>

namespace landmark_loop_closure {

namespace {

// How many of a map's first `keyframes` search holds within the memory budget (`database` is
// still exact: the graph's links are counted as `index` will add them).
size_t keyframesWithinBudget(const KeyframeDatabase& database, const IndexOptions& index,
                             size_t row_stride, size_t keyframes, double budget_mb) {
  if (budget_mb <= 0.0) return keyframes;
  const size_t graph_bytes =
      index.buildsGraph() ? ApproximateIndex::bytesPerRow(index.neighbors) : 0;
  const auto fit = static_cast<size_t>(
      budget_mb * 1e6 / static_cast<double>(database.bytesPerKeyframe(row_stride) + graph_bytes));
  return std::min(keyframes, fit);
}

}  // namespace

std::string missingMapProblem(const std::string& path) {
  std::error_code error;
  return std::filesystem::exists(path, error) ? "" : "map " + path + ": does not exist";
}

void readRecordsFrom(KeyframeDatabase* database, const KeyframeStore* store, size_t cached) {
  database->readRecordsFrom(
      [store](uint64_t id) -> std::optional<KeyframeRecord> {
        try {
          return store->get(id);
        } catch (const std::exception&) {
          return std::nullopt;  // A damaged record: its candidate is reported unreadable.
        }
      },
      cached);
}

ReadMap readMap(const std::string& path, const MapReadSettings& settings) {
  IndexOptions exact = settings.index;
  exact.type = "exact";  // The graph is read, or built once, after every keyframe is in.
  ReadMap map{KeyframeStore::open(path, settings.descriptor_identity, settings.global_dimension),
              KeyframeDatabase(settings.global_dimension, exact), settings.descriptor_identity};
  KeyframeStore& store = *map.store;
  map.keyframes = store.size();
  // Only what search needs is read; records come from the file for each query's candidates.
  // Past the memory budget the map's later keyframes stay on disk, not searched.
  size_t searched = keyframesWithinBudget(map.database, settings.index, store.rowStride(),
                                          map.keyframes, settings.memory_budget_mb);
  if (settings.index.buildsGraph() && searched < map.keyframes) {
    // A graph saved over more (the budget was lowered since) is used whole: building one over
    // fewer would hold the start for minutes (~2 ms per keyframe).
    searched = std::max(
        searched,
        std::min(map.keyframes, store.savedGraphKeyframes(settings.index.graphIdentity())));
  }
  store.loadSearch(&map.database, searched);
  // Keyframes are appended in id order, each run's session after the last: the map's last
  // keyframe (searched or not) has both the highest id and the highest session.
  if (const std::optional<KeyframeSummary> last = store.lastSummary()) {
    map.last_id = last->id;
    map.last_session = last->session;
  }
  readRecordsFrom(&map.database, &store, settings.cached_records);
  std::unique_ptr<ApproximateIndex> graph;
  if (settings.index.buildsGraph()) {
    // A graph saved before a crash lacks the last keyframes; setIndex links them in.
    graph = store.loadGraph(settings.index.graphIdentity(), map.database.vectors(),
                            settings.index.neighbors);
  }
  map.graph_reused = graph != nullptr;
  const size_t unlinked = map.database.size() - (graph ? graph->size() : 0);
  if (settings.index.buildsGraph() && unlinked > settings.graph_rows_built_inline) {
    // Seconds of work: exact search until the graph is swapped in (LoopDetector).
    map.graph_build = std::make_unique<BackgroundGraph>(
        map.database.vectors()->snapshot(map.database.size()), std::move(graph), settings.index);
  } else {
    map.database.setIndex(settings.index, std::move(graph));
  }
  // Reading the whole map would hold search back for seconds: it is checked meanwhile, and
  // keyframes are held from it until it passes.
  store.startIntegrityCheck();
  return map;
}

}  // namespace landmark_loop_closure
