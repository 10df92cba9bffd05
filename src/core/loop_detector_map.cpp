// LoopDetector and its map file: opening it (search within the memory budget, the rows checked
// beside search), storing keyframes in it and announcing them once committed, saving, copying
// and resetting it.
#include <algorithm>
#include <filesystem>
#include <optional>

#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/database/map_file_safety.h"
#include "landmark_loop_closure/database/map_tools.h"

namespace landmark_loop_closure {

namespace {

// What every save does before it writes: the target's checks (saveTargetProblem), then an
// existing map there (let through only with `overwrite`) kept aside under a unique name, given in
// `kept`. Returns "" or why not.
std::string clearSaveTarget(const std::string& path, const std::string& open_map, bool overwrite,
                            std::string* kept) {
  const std::string problem = saveTargetProblem(path, open_map, overwrite);
  if (!problem.empty()) return problem;
  try {
    std::error_code absent;
    if (std::filesystem::exists(path, absent)) *kept = moveMapAside(path, "replaced");
  } catch (const std::exception& error) {
    return error.what();
  }
  return "";
}

}  // namespace

std::string LoopDetector::saveDatabase(const std::string& path, bool overwrite,
                                       std::string* kept_as) {
  KeyframeResult unreported;
  storeWarmedUp(&unreported);  // A map saved now holds every keyframe so far.
  if (training_) {
    return "nothing to save yet: the broad autoencoder is still training (" +
           std::to_string(training_->held()) + " of " + std::to_string(training_->wanted()) +
           " keyframes held)";
  }
  if (store_ && path == store_->path()) return "";  // Every keyframe is committed already.
  std::string kept;
  const std::string refused = clearSaveTarget(path, mapPath(), overwrite, &kept);
  if (!refused.empty()) return refused;
  try {
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

std::string LoopDetector::beginSave(const std::string& path, bool overwrite, std::string* kept_as) {
  KeyframeResult unreported;
  storeWarmedUp(&unreported);
  save_.reset();
  save_abandoned_ = false;
  if (!store_ || training_ || path == store_->path()) {
    return saveDatabase(path, overwrite, kept_as);  // At once: nothing to copy page by page.
  }
  std::string kept;
  const std::string refused = clearSaveTarget(path, mapPath(), overwrite, &kept);
  if (!refused.empty()) return refused;
  save_ = store_->startCopy(path);
  if (kept_as) *kept_as = kept;
  return "";
}

bool LoopDetector::continueSave(int pages) {
  if (save_abandoned_) {
    save_abandoned_ = false;
    throw std::runtime_error(
        "the map was replaced (a load or a reset) while it was being copied: "
        "nothing was written");
  }
  return !save_ || save_->step(pages);
}

void LoopDetector::abandonSave() {
  if (!save_) return;
  save_.reset();
  save_abandoned_ = true;
}

std::string LoopDetector::openMap(const std::string& path) {
  if (training_) {
    // The map's descriptor identity is known once training has made the descriptor.
    pending_map_path_ = path;
    return "";
  }
  try {
    return adoptMap(readMap(path, mapReadSettings()));
  } catch (const std::exception& error) {
    return error.what();
  }
}

MapReadSettings LoopDetector::mapReadSettings() const {
  MapReadSettings settings;
  settings.index = options_.database.index;  // The database's may be exact while its graph builds.
  settings.global_dimension = database_.globalDimension();
  settings.descriptor_identity = descriptor_identity_;
  settings.memory_budget_mb = options_.database.memory_budget_mb;
  settings.cached_records = cachedRecords();
  return settings;
}

std::string LoopDetector::adoptMap(ReadMap map) {
  if (training_ || map.descriptor_identity != descriptor_identity_) {
    return "map " + map.store->path() +
           ": not switched to, the descriptor changed while it was read (online training)";
  }
  KeyframeResult unreported;
  storeWarmedUp(&unreported);  // They belong to the map open until now.
  abandonSave();               // It copies the map replaced here.
  map_graph_reused_ = map.graph_reused;
  graph_build_ = std::move(map.graph_build);
  map_leftovers_removed_ = map.store->leftoversRemoved();
  map_repairs_ = map.store->repairs();
  map_damage_.clear();
  map_unwritten_ = 0;
  map_unsearched_ = map.keyframes - map.database.size();
  database_ = std::move(map.database);
  store_ = std::move(map.store);
  session_ = map.keyframes == 0 ? 0 : map.last_session + 1;
  // After the map's last keyframe, and after any id it published before storing (warm-up).
  const std::optional<uint64_t> reserved =
      store_ ? store_->idsReservedThrough() : std::optional<uint64_t>();
  const bool any = map.keyframes > 0 || reserved.has_value();
  const uint64_t after =
      std::max(map.keyframes > 0 ? map.last_id + 1 : 0, reserved ? *reserved + 1 : 0);
  uint64_t next = next_keyframe_id_.load();
  while (any && next < after && !next_keyframe_id_.compare_exchange_weak(next, after)) {
  }
  consistency_.reset();
  sequence_.reset();
  backgrounds_.clear();
  last_loop_.reset();
  passed_places_.clear();
  last_keyframe_.reset();
  return "";
}

size_t LoopDetector::cachedRecords() const {
  // The newest keyframes (triangulation, the consistency chain) and a few queries' candidates.
  return static_cast<size_t>(4 * options_.database.top_k + options_.triangulation_keyframes +
                             options_.acceptance.sequence.length) +
         16;
}

std::string LoopDetector::saveMapGraph() {
  if (!store_) return "";
  KeyframeResult unreported;
  storeWarmedUp(&unreported);  // The graph, and the counts said at a stop, include them.
  adoptBuiltGraph(true);       // A graph still building is finished and kept for the next start.
  try {
    store_->saveGraph(database_.indexOptions().graphIdentity(), database_);
  } catch (const std::exception& error) {
    return error.what();
  }
  return "";
}

std::string LoopDetector::loadDatabase(const std::string& path) {
  const std::string missing = missingMapProblem(path);
  return missing.empty() ? openMap(path) : missing;
}

size_t LoopDetector::mapKeyframesNotWritten() const {
  if (!store_) return 0;
  // Held during a check that failed: never committed.
  const size_t held =
      store_->integrityCheck() == KeyframeStore::MapCheck::kFailed ? store_->heldKeyframes() : 0;
  return map_unwritten_ + held;
}

size_t LoopDetector::mapKeyframesInFile() const {
  if (!store_) return 0;
  const bool failed = store_->integrityCheck() == KeyframeStore::MapCheck::kFailed;
  return store_->size() - (failed ? store_->heldKeyframes() : 0);
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
  KeyframeResult unreported;
  storeWarmedUp(&unreported);  // A reset keeps what came before it on disk.
  abandonSave();
  if (training_) training_->clear();
  map_damage_.clear();
  map_unsearched_ = 0;
  map_unwritten_ = 0;
  graph_build_.reset();
  database_ = KeyframeDatabase(database_.globalDimension(), options_.database.index);
  session_ = 0;
  memory_map_id_ = KeyframeStore::drawMapId();
  consistency_.reset();
  sequence_.reset();
  backgrounds_.clear();
  last_loop_.reset();
  passed_places_.clear();
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
    readRecordsFrom(&database_, store_.get(), cachedRecords());
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

void LoopDetector::reserveId(uint64_t id, KeyframeResult* result) {
  // Published now but stored later (the warm-up) or never (localisation): a restart, or a later
  // mapping run on the map, must not give the id to another frame.
  if (!store_ || !map_damage_.empty()) return;
  try {
    store_->reserveIdsThrough(id);
  } catch (const std::exception& error) {
    result->store_error = error.what();
  }
}

void LoopDetector::announce(const KeyframeRecord& keyframe, bool wait_for_commit) {
  if (!announcing_) return;
  AnnouncedKeyframe announced{mapId(), static_cast<const KeyframeSummary&>(keyframe)};
  // In id order: behind keyframes that still wait, whatever this one's state.
  if (wait_for_commit || !waiting_for_commit_.empty()) {
    waiting_for_commit_.push_back(std::move(announced));
  } else {
    announced_.push_back(std::move(announced));
  }
}

bool LoopDetector::awaitingCommit(uint64_t id) const {
  return std::any_of(waiting_for_commit_.begin(), waiting_for_commit_.end(),
                     [&](const AnnouncedKeyframe& waiting) {
                       return waiting.summary.id == id && waiting.map_id == mapId();
                     });
}

std::vector<AnnouncedKeyframe> LoopDetector::takeAnnounced() {
  if (store_ && map_damage_.empty() && store_->heldKeyframes() > 0) {
    try {
      store_->commitHeldIfChecked();
    } catch (const std::exception&) {
      // The disk refused them: they stay held, and the next keyframe's store says why.
    }
  }
  const std::optional<uint64_t> committed =
      store_ ? store_->lastCommittedId() : std::optional<uint64_t>();
  while (!waiting_for_commit_.empty()) {
    const AnnouncedKeyframe& next = waiting_for_commit_.front();
    // Released once committed, or once no file will take it: the map switched (closing it
    // commits what it held), was found damaged, or holds nothing back any more.
    const bool settled = !store_ || next.map_id != store_->mapId() || !map_damage_.empty() ||
                         store_->heldKeyframes() == 0 ||
                         (committed && next.summary.id <= *committed);
    if (!settled) break;
    announced_.push_back(std::move(waiting_for_commit_.front()));
    waiting_for_commit_.pop_front();
  }
  std::vector<AnnouncedKeyframe> ready = std::move(announced_);
  announced_.clear();
  return ready;
}

void LoopDetector::storeWarmedUp(KeyframeResult* result) {
  std::vector<WarmingKeyframe> warming = std::move(warming_);
  warming_.clear();
  for (WarmingKeyframe& waiting : warming) {
    if (!standardiser_.warmingUp()) {
      waiting.keyframe.descriptor.global = standardiser_.standardise(waiting.raw_global);
    }
    store(std::move(waiting.keyframe), result);
  }
}

void LoopDetector::store(KeyframeRecord keyframe, KeyframeResult* result) {
  noteMapDamage(result);
  if (!map_damage_.empty()) {
    // A damaged map is left as it is: keyframes stay in memory (mapDamage() said so once).
    ++map_unwritten_;
    result->stored = true;
    announce(keyframe, false);
    database_.addUnstored(std::move(keyframe));
    return;
  }
  const bool over_budget = overMemoryBudget();
  if (over_budget && !store_) {
    announce(keyframe, false);
    return;
  }
  if (store_) {
    bool written = false;
    try {
      store_->add(keyframe);  // Committed before it is searched for: a crash cannot lose it.
      written = true;
    } catch (const std::exception& error) {
      result->store_error = error.what();
      ++map_unwritten_;
    }
    // Held by the map's check: announced once committed.
    const std::optional<uint64_t> committed = store_->lastCommittedId();
    announce(keyframe, written && (!committed || *committed < keyframe.id));
    if (!written && over_budget) return;
  } else {
    announce(keyframe, false);
  }
  result->stored = true;
  if (over_budget) {
    // The budget bounds search's RAM, not the map: the keyframe went to disk only.
    result->written_not_searched = true;
  } else if (result->store_error.empty()) {
    database_.add(std::move(keyframe));
  } else {
    database_.addUnstored(std::move(keyframe));  // Disk full: kept in RAM, still compared.
  }
}

std::optional<int64_t> LoopDetector::keyframeStampNs(uint64_t id) const {
  const std::optional<size_t> index = database_.indexOf(id);
  if (!index) return std::nullopt;
  const std::shared_ptr<const KeyframeRecord> record = database_.record(*index);
  if (!record) return std::nullopt;
  return record->stamp_ns;
}

void LoopDetector::adoptBuiltGraph(bool wait) {
  if (!graph_build_ || (!wait && !graph_build_->ready())) return;
  std::unique_ptr<ApproximateIndex> graph = graph_build_->take();
  if (graph) {
    graph->rebind(database_.vectors());
    database_.setIndex(options_.database.index, std::move(graph));  // Links the rows added since.
  } else {
    database_.setIndex(options_.database.index);  // The build failed: one more try, here.
  }
  graph_build_.reset();
}

}  // namespace landmark_loop_closure
