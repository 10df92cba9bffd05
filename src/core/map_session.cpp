#include "landmark_loop_closure/core/map_session.h"

#include <algorithm>
#include <filesystem>
#include <optional>

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

MapSession::MapSession(Settings settings, MapUser* user)
    : settings_(std::move(settings)),
      user_(user),
      database_(settings_.global_dimension, settings_.database.index) {}

std::string MapSession::save(const std::string& path, bool overwrite, std::string* kept_as) {
  storeHeldKeyframes();                             // A map saved now holds every keyframe so far.
  if (store_ && path == store_->path()) return "";  // Every keyframe is committed already.
  std::string kept;
  const std::string refused = clearSaveTarget(path, this->path(), overwrite, &kept);
  if (!refused.empty()) return refused;
  try {
    if (store_) {
      store_->copyTo(path);
    } else {
      writeMap(database_, settings_.descriptor_identity, path);
    }
  } catch (const std::exception& error) {
    return std::string(error.what()) + (kept.empty() ? "" : "; the earlier map is kept as " + kept);
  }
  if (kept_as) *kept_as = kept;
  return "";
}

std::string MapSession::beginSave(const std::string& path, bool overwrite, std::string* kept_as) {
  storeHeldKeyframes();
  save_.reset();
  save_abandoned_ = false;
  if (!store_ || path == store_->path()) {
    return save(path, overwrite, kept_as);  // At once: nothing to copy page by page.
  }
  std::string kept;
  const std::string refused = clearSaveTarget(path, this->path(), overwrite, &kept);
  if (!refused.empty()) return refused;
  save_ = store_->startCopy(path);
  if (kept_as) *kept_as = kept;
  return "";
}

bool MapSession::continueSave(int pages) {
  if (save_abandoned_) {
    save_abandoned_ = false;
    throw std::runtime_error(
        "the map was replaced (a load or a reset) while it was being copied: "
        "nothing was written");
  }
  return !save_ || save_->step(pages);
}

void MapSession::abandonSave() {
  if (!save_) return;
  save_.reset();
  save_abandoned_ = true;
}

std::string MapSession::open(const std::string& path) {
  try {
    return adopt(readMap(path, readSettings()));
  } catch (const std::exception& error) {
    return error.what();
  }
}

MapReadSettings MapSession::readSettings() const {
  MapReadSettings settings;
  settings.index = settings_.database.index;  // The database's may be exact while its graph builds.
  settings.global_dimension = database_.globalDimension();
  settings.descriptor_identity = settings_.descriptor_identity;
  settings.memory_budget_mb = settings_.database.memory_budget_mb;
  settings.cached_records = settings_.cached_records;
  return settings;
}

std::string MapSession::adopt(ReadMap map) {
  if (map.descriptor_identity != settings_.descriptor_identity) {
    return "map " + map.store->path() + ": not switched to, it was read for another descriptor";
  }
  storeHeldKeyframes();  // They belong to the map open until now.
  abandonSave();         // It copies the map replaced here.
  graph_reused_ = map.graph_reused;
  graph_build_ = std::move(map.graph_build);
  leftovers_removed_ = map.store->leftoversRemoved();
  repairs_ = map.store->repairs();
  damage_.clear();
  unwritten_ = 0;
  unsearched_ = map.keyframes - map.database.size();
  database_ = std::move(map.database);
  store_ = std::move(map.store);
  // After the map's last keyframe, and after any id it published before storing (warm-up).
  const std::optional<uint64_t> reserved = store_->idsReservedThrough();
  std::optional<uint64_t> next_id;
  if (map.keyframes > 0 || reserved) {
    next_id = std::max(map.keyframes > 0 ? map.last_id + 1 : 0, reserved ? *reserved + 1 : 0);
  }
  // After every session of the map: its keyframes' and those runs that stored none used
  // (localisation), so no two runs share one.
  std::optional<uint32_t> last_session;
  if (map.keyframes > 0) last_session = map.last_session;
  if (const std::optional<uint32_t> reserved = store_->sessionsReservedThrough()) {
    last_session = std::max(last_session.value_or(0), *reserved);
  }
  const uint32_t first_session = last_session ? *last_session + 1 : 0;
  write_problem_.clear();
  if (user_) user_->mapReplaced(first_session, next_id);
  return "";
}

std::string MapSession::saveGraph() {
  if (!store_) return "";
  storeHeldKeyframes();   // The graph, and the counts said at a stop, include them.
  adoptBuiltGraph(true);  // A graph still building is finished and kept for the next start.
  try {
    store_->saveGraph(database_.indexOptions().graphIdentity(), database_);
  } catch (const std::exception& error) {
    return error.what();
  }
  return "";
}

std::string MapSession::load(const std::string& path) {
  const std::string missing = missingMapProblem(path);
  return missing.empty() ? open(path) : missing;
}

size_t MapSession::keyframesNotWritten() const {
  if (!store_) return 0;
  // Held during a check that failed: never committed.
  const size_t held =
      store_->integrityCheck() == KeyframeStore::MapCheck::kFailed ? store_->heldKeyframes() : 0;
  return unwritten_ + held;
}

size_t MapSession::keyframesInFile() const {
  if (!store_) return 0;
  const bool failed = store_->integrityCheck() == KeyframeStore::MapCheck::kFailed;
  return store_->size() - (failed ? store_->heldKeyframes() : 0);
}

std::string MapSession::check() const {
  if (!store_) return "";
  switch (store_->integrityCheck()) {
    case KeyframeStore::MapCheck::kPassed:
      return "checked";
    case KeyframeStore::MapCheck::kFailed:
      return "damaged";
    case KeyframeStore::MapCheck::kDeferred:
      return "not checked yet: " + store_->integrityDeferredBy();
    case KeyframeStore::MapCheck::kPending:
    case KeyframeStore::MapCheck::kRunning:
      break;
  }
  return "being checked";
}

MapSession::ResetOutcome MapSession::reset() {
  storeHeldKeyframes();  // A reset keeps what came before it on disk.
  abandonSave();
  damage_.clear();
  unsearched_ = 0;
  unwritten_ = 0;
  write_problem_.clear();
  graph_build_.reset();
  database_ = KeyframeDatabase(database_.globalDimension(), settings_.database.index);
  memory_map_id_ = KeyframeStore::drawMapId();
  if (user_) user_->mapReplaced(0, std::nullopt);
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
    store_ = KeyframeStore::open(path, settings_.descriptor_identity, database_.globalDimension());
    readRecordsFrom(&database_, store_.get(), settings_.cached_records);
  } catch (const std::exception& open_error) {
    outcome.problem = "no fresh map could start at " + path + ": " + open_error.what() +
                      "; keyframes are kept in memory only";
  }
  return outcome;
}

bool MapSession::overMemoryBudget() const {
  const double budget = settings_.database.memory_budget_mb;
  return budget > 0.0 && static_cast<double>(database_.bytes()) >= budget * 1e6;
}

std::string MapSession::reserveId(uint64_t id) {
  // Published now but stored later (the warm-up) or never (localisation): a restart, or a later
  // mapping run on the map, must not give the id to another frame.
  if (!store_ || !damage_.empty()) return "";
  try {
    store_->reserveIdsThrough(id);
  } catch (const std::exception& error) {
    write_problem_ = error.what();
    return error.what();
  }
  return "";
}

std::string MapSession::reserveUnstored(uint64_t id, uint32_t session) {
  if (!store_ || !damage_.empty()) return "";
  // Ahead of need: a map that cannot be written for a while (a full disk) still takes this run's
  // next keyframes, and the map is written once per block, not per keyframe.
  const std::optional<uint64_t> reserved = store_->idsReservedThrough();
  const std::optional<uint32_t> sessions = store_->sessionsReservedThrough();
  const bool reserved_already = reserved && id <= *reserved && sessions && session <= *sessions &&
                                store_->idsReservedInFile() == reserved;
  if (reserved_already) return "";
  store_->reserveSession(session);
  return reserveId(reserved && id <= *reserved ? *reserved : id + kUnstoredIdBlock - 1);
}

void MapSession::announce(const KeyframeSummary& keyframe, bool wait_for_commit) {
  if (!announcing_) return;
  AnnouncedKeyframe announced{mapId(), keyframe};
  // In id order: behind keyframes that still wait, whatever this one's state.
  if (wait_for_commit || !waiting_for_commit_.empty()) {
    waiting_for_commit_.push_back({std::move(announced), !wait_for_commit});
  } else {
    announced_.push_back(std::move(announced));
  }
}

void MapSession::announceUnstored(const KeyframeSummary& keyframe) {
  if (!announcing_) return;
  waiting_for_commit_.push_back({AnnouncedKeyframe{mapId(), keyframe}, false, true});
}

bool MapSession::awaitingCommit(uint64_t id) const {
  return std::any_of(
      waiting_for_commit_.begin(), waiting_for_commit_.end(), [&](const Waiting& waiting) {
        return waiting.announced.summary.id == id && waiting.announced.map_id == mapId();
      });
}

std::vector<AnnouncedKeyframe> MapSession::takeAnnounced() {
  if (store_ && damage_.empty() && (store_->heldKeyframes() > 0 || store_->reservationUnsaved())) {
    try {
      store_->commitHeldIfChecked();
    } catch (const std::exception&) {
      // The disk refused them: they stay held, and the next keyframe's store says why.
    }
  }
  const std::optional<uint64_t> committed =
      store_ ? store_->lastCommittedId() : std::optional<uint64_t>();
  const std::optional<uint64_t> reserved =
      store_ ? store_->idsReservedInFile() : std::optional<uint64_t>();
  while (!waiting_for_commit_.empty()) {
    const Waiting& waiting = waiting_for_commit_.front();
    const AnnouncedKeyframe& next = waiting.announced;
    // Released once the file holds it (committed; for a keyframe stored nowhere, its id's
    // reservation), or once no file will take it: the map switched (closing it commits what it
    // held) or was found damaged (kept in memory, as damage() said).
    const std::optional<uint64_t>& held_through = waiting.stored_nowhere ? reserved : committed;
    const bool settled = waiting.ready || !store_ || next.map_id != store_->mapId() ||
                         !damage_.empty() || (held_through && next.summary.id <= *held_through);
    if (!settled) break;
    announced_.push_back(std::move(waiting_for_commit_.front().announced));
    waiting_for_commit_.pop_front();
  }
  std::vector<AnnouncedKeyframe> ready = std::move(announced_);
  announced_.clear();
  return ready;
}

std::string MapSession::takeNewDamage() {
  if (store_ && damage_.empty() && store_->integrityCheck() == KeyframeStore::MapCheck::kFailed) {
    damage_ = store_->integrityProblem();
    return damage_;
  }
  return "";
}

QueryResult MapSession::query(const std::vector<float>& global, double stamp,
                              const DatabaseOptions& search, uint32_t session) {
  adoptBuiltGraph(false);
  if (!damage_.empty()) {
    QueryResult damaged;
    damaged.status = QueryStatus::kMapDamaged;  // Its rows cannot be trusted to find loops.
    return damaged;
  }
  return database_.query(global, stamp, search, session);
}

StoredKeyframe MapSession::store(KeyframeRecord keyframe) {
  StoredKeyframe outcome;
  outcome.map_damage = takeNewDamage();
  if (!damage_.empty()) {
    // A damaged map is left as it is: keyframes stay in memory (damage() said so once).
    ++unwritten_;
    outcome.stored = true;
    announce(keyframe, false);
    database_.addUnstored(std::move(keyframe));
    return outcome;
  }
  const bool over_budget = overMemoryBudget();
  if (over_budget && !store_) {
    announce(keyframe, false);
    return outcome;
  }
  if (store_) {
    try {
      store_->add(keyframe);  // Committed before it is searched for: a crash cannot lose it.
    } catch (const std::exception& error) {
      // Not in the file: neither announced nor searched, so that no backend hears of a keyframe
      // the map lacks and no loop names one; its id is never announced, so a later run may
      // give it again. The next keyframe tries the file again.
      outcome.store_error = error.what();
      write_problem_ = error.what();
      ++unwritten_;
      return outcome;
    }
    write_problem_.clear();
    // Held by the map's check: announced once committed.
    const std::optional<uint64_t> committed = store_->lastCommittedId();
    announce(keyframe, !committed || *committed < keyframe.id);
  } else {
    announce(keyframe, false);
  }
  outcome.stored = true;
  if (over_budget) {
    // The budget bounds search's RAM, not the map: the keyframe went to disk only.
    outcome.written_not_searched = true;
  } else {
    database_.add(std::move(keyframe));
  }
  return outcome;
}

std::optional<int64_t> MapSession::keyframeStampNs(uint64_t id) const {
  const std::optional<size_t> index = database_.indexOf(id);
  if (!index) return std::nullopt;
  const std::shared_ptr<const KeyframeRecord> record = database_.record(*index);
  if (!record) return std::nullopt;
  return record->stamp_ns;
}

void MapSession::adoptBuiltGraph(bool wait) {
  if (!graph_build_ || (!wait && !graph_build_->ready())) return;
  std::unique_ptr<ApproximateIndex> graph = graph_build_->take();
  if (graph) {
    graph->rebind(database_.vectors());
    database_.setIndex(settings_.database.index, std::move(graph));  // Links the rows added since.
  } else {
    database_.setIndex(settings_.database.index);  // The build failed: one more try, here.
  }
  graph_build_.reset();
}

}  // namespace landmark_loop_closure
