// LoopDetector and its map file: opening it (search within the memory budget, the rows checked
// beside search), saving, copying and resetting it.
#include <algorithm>
#include <filesystem>
#include <optional>

#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/database/map_file_safety.h"
#include "landmark_loop_closure/database/map_tools.h"

namespace landmark_loop_closure {

std::string LoopDetector::saveDatabase(const std::string& path, bool overwrite,
                                       std::string* kept_as) const {
  if (training_) {
    return "nothing to save yet: the broad autoencoder is still training (" +
           std::to_string(training_->held()) + " of " + std::to_string(training_->wanted()) +
           " keyframes held)";
  }
  if (store_ && path == store_->path()) return "";  // Every keyframe is committed already.
  const std::string problem = saveTargetProblem(path, mapPath(), overwrite);
  if (!problem.empty()) return problem;
  std::string kept;
  try {
    // saveTargetProblem let an existing file through only as a map to overwrite.
    std::error_code absent;
    if (std::filesystem::exists(path, absent)) kept = moveMapAside(path, "replaced");
    if (store_) {
      store_->copyTo(path);
    } else {
      writeMap(database_, descriptor_identity_, path);
    }
  } catch (const std::exception& error) {
    return std::string(error.what()) + (kept.empty() ? "" : "; the earlier map is kept as " + kept);
  }
  if (kept_as) *kept_as = kept;
  return "";
}

std::string LoopDetector::openMap(const std::string& path) {
  if (training_) {
    // The map's descriptor identity is known once training has made the descriptor.
    pending_map_path_ = path;
    return "";
  }
  std::unique_ptr<KeyframeStore> store;
  const IndexOptions index = database_.indexOptions();
  IndexOptions exact = index;
  exact.type = "exact";  // The graph is read, or built once, after every keyframe is in.
  KeyframeDatabase loaded(database_.globalDimension(), exact);
  bool graph_reused = false;
  uint32_t last_session = 0;
  uint64_t last_id = 0;
  size_t map_keyframes = 0;
  try {
    store = KeyframeStore::open(path, descriptor_identity_, database_.globalDimension());
    map_keyframes = store->size();
    // Only what search needs is read; records come from the file for each query's candidates.
    // Past the memory budget the map's later keyframes stay on disk, not searched.
    size_t searched = keyframesWithinBudget(store->rowStride(), map_keyframes);
    if (index.buildsGraph() && searched < map_keyframes) {
      // A graph saved over more (the budget was lowered since) is used whole: building one over
      // fewer would hold the start for minutes (~2 ms per keyframe).
      searched = std::max(
          searched, std::min(map_keyframes, store->savedGraphKeyframes(index.graphIdentity())));
    }
    store->loadSearch(&loaded, searched);
    // Keyframes are appended in id order, each run's session after the last: the map's last
    // keyframe (searched or not) has both the highest id and the highest session.
    if (const std::optional<KeyframeSummary> last = store->lastSummary()) {
      last_id = last->id;
      last_session = last->session;
    }
    readRecordsFromStore(&loaded, store.get());
    std::unique_ptr<ApproximateIndex> graph;
    if (index.buildsGraph()) {
      // A graph saved before a crash lacks the last keyframes; setIndex links them in.
      graph = store->loadGraph(index.graphIdentity(), loaded.vectors(), index.neighbors);
    }
    graph_reused = graph != nullptr;
    loaded.setIndex(index, std::move(graph));
    // Reading the whole map would hold search back for seconds: it is checked meanwhile, and
    // keyframes are held from it until it passes.
    store->startIntegrityCheck();
  } catch (const std::exception& error) {
    return error.what();
  }
  map_graph_reused_ = graph_reused;
  map_leftovers_removed_ = store->leftoversRemoved();
  map_repairs_ = store->repairs();
  map_damage_.clear();
  map_unsearched_ = map_keyframes - loaded.size();
  database_ = std::move(loaded);
  store_ = std::move(store);
  session_ = map_keyframes == 0 ? 0 : last_session + 1;
  uint64_t next = next_keyframe_id_.load();
  while (map_keyframes > 0 && next <= last_id &&
         !next_keyframe_id_.compare_exchange_weak(next, last_id + 1)) {
  }
  consistency_.reset();
  sequence_.reset();
  last_keyframe_.reset();
  return "";
}

size_t LoopDetector::keyframesWithinBudget(size_t row_stride, size_t keyframes) const {
  const double budget = options_.database.memory_budget_mb;
  if (budget <= 0.0) return keyframes;
  const auto fit = static_cast<size_t>(budget * 1e6 /
                                       static_cast<double>(database_.bytesPerKeyframe(row_stride)));
  return std::min(keyframes, fit);
}

void LoopDetector::readRecordsFromStore(KeyframeDatabase* database, const KeyframeStore* store) {
  // The newest keyframes (triangulation, the consistency chain) and a few queries' candidates.
  const size_t cached =
      static_cast<size_t>(4 * options_.database.top_k + options_.triangulation_keyframes +
                          options_.acceptance.sequence.length) +
      16;
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

std::string LoopDetector::saveMapGraph() {
  if (!store_) return "";
  try {
    store_->saveGraph(database_.indexOptions().graphIdentity(), database_);
  } catch (const std::exception& error) {
    return error.what();
  }
  return "";
}

std::string LoopDetector::loadDatabase(const std::string& path) {
  if (!std::filesystem::exists(path)) return "map " + path + ": does not exist";
  return openMap(path);
}

std::string LoopDetector::mapCheck() const {
  if (!store_) return "";
  switch (store_->integrityCheck()) {
    case KeyframeStore::MapCheck::kPassed:
      return "checked";
    case KeyframeStore::MapCheck::kFailed:
      return "damaged";
    case KeyframeStore::MapCheck::kPending:
    case KeyframeStore::MapCheck::kRunning:
      break;
  }
  return "being checked";
}

LoopDetector::ResetOutcome LoopDetector::reset() {
  if (training_) training_->clear();
  map_damage_.clear();
  map_unsearched_ = 0;
  database_ = KeyframeDatabase(database_.globalDimension(), database_.indexOptions());
  session_ = 0;
  memory_map_id_ = KeyframeStore::drawMapId();
  consistency_.reset();
  sequence_.reset();
  last_keyframe_.reset();
  ResetOutcome outcome;
  if (!store_ || store_->size() == 0) return outcome;
  // The forgotten keyframes stay on disk: a reset never shortens a saved map.
  const std::string path = store_->path();
  store_.reset();
  std::error_code error_code;
  if (!std::filesystem::exists(path, error_code)) {
    outcome.problem = "the map " + path +
                      " is gone (deleted or moved while open): nothing was kept aside; keyframes "
                      "are kept in memory only";
    return outcome;
  }
  try {
    // A unique name, never one an earlier reset (even in the same second) kept a map under.
    outcome.kept_as = moveMapAside(path, "reset");
  } catch (const std::exception& error) {
    outcome.problem = std::string(error.what()) + "; keyframes are kept in memory only";
    return outcome;
  }
  try {
    store_ = KeyframeStore::open(path, descriptor_identity_, database_.globalDimension());
    readRecordsFromStore(&database_, store_.get());
  } catch (const std::exception& open_error) {
    outcome.problem = "no fresh map could start at " + path + ": " + open_error.what() +
                      "; keyframes are kept in memory only";
  }
  return outcome;
}

bool LoopDetector::overMemoryBudget() const {
  const double budget = options_.database.memory_budget_mb;
  return budget > 0.0 && static_cast<double>(database_.bytes()) >= budget * 1e6;
}

}  // namespace landmark_loop_closure
