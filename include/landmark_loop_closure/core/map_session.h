#pragma once

// The map's life in one place: the keyframes search holds in memory and, when one is open, the
// map file that keeps them (KeyframeStore). Opening or adopting a map, storing keyframes in it
// and announcing them once committed, saving it (at once or in steps), resetting it, and the
// damage its integrity check finds all happen here; LoopDetector keeps admission, description,
// search and the decision, and is told when the map it searches is replaced.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "landmark_loop_closure/core/map_reading.h"
#include "landmark_loop_closure/database/background_graph.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/database/map_copy.h"

namespace landmark_loop_closure {

/// A keyframe safe to publish: committed to the map file (or kept where no file will hold it).
struct AnnouncedKeyframe {
  uint64_t map_id = 0;  ///< The map it is stored in (MapSession::mapId() when it was stored).
  KeyframeSummary summary;
};

/// What happened to a keyframe MapSession::store() was given.
struct StoredKeyframe {
  /// Kept: false only past the memory budget without a map file.
  bool stored = false;
  /// Past advanced/database/memory_budget_mb with a map file: written to the map, not searched.
  bool written_not_searched = false;
  std::string store_error;  ///< Not committed to the map file (disk full, file gone): why.
  std::string map_damage;   ///< The map's check failed just now (said once).
};

/// What the user of the map (the detector) does around its life: it may hold keyframes back from
/// the map (the condition window's warm-up), and keeps state about the map it searches.
class MapUser {
 public:
  virtual ~MapUser() = default;
  /// Before the map is saved, replaced or reset: stores the keyframes held back, so that the
  /// saved map, or the one replaced, holds every keyframe so far.
  virtual void storeHeldKeyframes() = 0;
  /// After another map became the one searched (an adopted map, a reset): `first_session` is the
  /// session new keyframes get; `next_id`, when set, the least id a new keyframe may get.
  virtual void mapReplaced(uint32_t first_session, std::optional<uint64_t> next_id) = 0;
};

/// The map searched and kept: see the file comment. Worker thread throughout, unless a method
/// says otherwise.
class MapSession {
 public:
  /// Search's options, the descriptor every map must have been made with, and how many records
  /// stay in memory.
  struct Settings {
    DatabaseOptions database;
    int global_dimension = 1;
    std::string descriptor_identity;  ///< Extractor name and descriptorIdentity().
    /// Records kept in memory when search reads them from a map file: the newest keyframes
    /// (triangulation, the consistency chain) and a few queries' candidates.
    size_t cached_records = 16;
  };
  /// `user` is told about the map's life (null: nobody is).
  MapSession(Settings settings, MapUser* user);
  MapSession(const MapSession&) = delete;
  MapSession& operator=(const MapSession&) = delete;

  /// The map at `path` (a KeyframeStore, created when missing) becomes the one searched: its
  /// keyframes are loaded as earlier sessions (new keyframes get the next session number and ids
  /// after every loaded one; the user forgets its chains), and every keyframe stored from now on
  /// is committed to it when it is added. Past advanced/database/memory_budget_mb only the map's
  /// first keyframes are searched (keyframesNotSearched()); the rows are checked beside search
  /// (damage()). On refusal returns why and changes nothing; "" on success. Open it before frames
  /// are admitted: ids already handed out below the loaded ones are refused.
  std::string open(const std::string& path);
  /// open() on an existing file: a missing one is refused, not created.
  std::string load(const std::string& path);
  /// What readMap() needs to read a map for this session, so that it can run on another thread
  /// while the worker goes on (a load), its result swapped in by adopt().
  MapReadSettings readSettings() const;
  /// `map` (readMap() with readSettings()) becomes the one searched, as open() says. Refused ("" or
  /// why) when it was read for another descriptor.
  std::string adopt(ReadMap map);

  /// What reset() did with the open map's file.
  struct ResetOutcome {
    std::string kept_as;  ///< Where the earlier map was kept; empty without one.
    /// Empty when the earlier map was kept and a fresh one started at its path; otherwise why
    /// not (the keyframes are forgotten all the same, new ones are kept in memory only).
    std::string problem;
  };
  /// Forgets every keyframe (the user its chains and sessions). With a map open, its file is kept
  /// under a new name and a fresh map starts at its path; a reset never shortens a saved map.
  ResetOutcome reset();

  /// Writes a copy of the keyframes to `path` as a map (atomically: the copy appears whole or not
  /// at all). The open map's own path: nothing to do, every keyframe is committed. Refused before
  /// anything is written (saveTargetProblem): the open map under another name, what is not a
  /// regular file, an existing file unless `overwrite` (then only a map, which is first kept aside
  /// under a unique name, given in `kept_as`). Returns "" or why.
  std::string save(const std::string& path, bool overwrite = false, std::string* kept_as = nullptr);
  /// save() in steps, so that keyframes go on between them (the node's ~save_database): checks
  /// the target and keeps an existing map aside as save() does, then copies nothing yet. Returns
  /// "" or why. Without a map file the keyframes are written at once.
  std::string beginSave(const std::string& path, bool overwrite, std::string* kept_as);
  /// Copies up to `pages` more pages of the map (SQLite pages: 2 KB); true once the copy is ready
  /// for takeSave(). Throws std::runtime_error: the copy failed, or a load or reset replaced the
  /// map meanwhile (the copy is abandoned and removed).
  bool continueSave(int pages);
  /// The copy to finish (MapCopy::finish(): the rows file and the rename) on any thread; null
  /// when beginSave() wrote the map at once.
  std::unique_ptr<MapCopy> takeSave() { return std::move(save_); }
  /// Keeps the search graph and summaries beside the open map for the next start (they change
  /// with every keyframe, so they are written at shutdown, not as keyframes come), after storing
  /// the keyframes the user holds back. Returns "" or why.
  std::string saveGraph();

  /// Why search stopped, "" while it runs. open() starts search at once and checks the map's
  /// integrity (its pages, and the rows sealed at its last clean shutdown) on a thread of its own
  /// (seconds for a large map), holding new keyframes from the file until it passes; when the map
  /// turns out damaged, nothing is searched from then on (query() says kMapDamaged: no loop is
  /// published) and nothing more is written to it: keyframes are kept in memory only (a reset
  /// starts a new map beside it).
  const std::string& damage() const { return damage_; }
  /// Sets damage() when the map's check has just failed and returns it, once ("" otherwise).
  std::string takeNewDamage();
  /// "checked", "being checked" or "damaged" ("" without a map file).
  std::string check() const;
  /// Keyframes of the open map left out of search at open, past
  /// advanced/database/memory_budget_mb: the map's first keyframes that fit it are searched, or
  /// those its saved search graph covers when more (delete PATH-graph to have it built within the
  /// budget).
  size_t keyframesNotSearched() const { return unsearched_; }
  /// Keyframes of this run the open map file will not hold: the map was found damaged (those held
  /// during its check, and every one after: in memory only) or a write failed (disk full: not
  /// kept at all, neither announced nor searched). 0 without a map file.
  size_t keyframesNotWritten() const;
  /// Keyframes the open map file holds, or will once its check passes.
  size_t keyframesInFile() const;
  /// Whether the last open() found the map's saved search graph (else it was built).
  bool graphReused() const { return graph_reused_; }
  /// The open map's search graph is being built in the background (search is exact until it is
  /// swapped in, at the first search after it is ready).
  bool graphBuilding() const { return graph_build_ != nullptr; }
  /// Tests and offline tools: waits for that graph and swaps it in.
  void awaitGraph() { adoptBuiltGraph(true); }
  /// Temporary files of an interrupted save that opening the map removed.
  const std::vector<std::string>& leftoversRemoved() const { return leftovers_removed_; }
  /// What opening the map repaired (keyframes a power cut left without their search rows).
  const std::vector<std::string>& repairs() const { return repairs_; }
  /// The open map's file, or "" when keyframes live in memory only.
  std::string path() const { return store_ ? store_->path() : ""; }
  /// The identity of the map keyframes are stored in (KeyframeStore::mapId, or one drawn for a
  /// map in memory only). Keyframe ids repeat between maps (a loaded map keeps its own);
  /// (mapId(), keyframe id) never does. A reset starts a map with a new identity.
  uint64_t mapId() const { return store_ ? store_->mapId() : memory_map_id_; }
  /// Search holds advanced/database/memory_budget_mb: new keyframes are searched for loops and
  /// written to the map file, if one is open, but not added to search.
  bool overMemoryBudget() const;

  /// The keyframes searched (any thread that holds the detector).
  const KeyframeDatabase& database() const { return database_; }
  /// The exact stamp (ns) of a stored keyframe, as its record keeps it (read from the map for a
  /// loaded one); nullopt when it is not in search or its record cannot be read.
  std::optional<int64_t> keyframeStampNs(uint64_t id) const;

  /// From now on, keyframes are collected for takeAnnounced() (off by default, so offline
  /// replays keep nothing extra).
  void announceKeyframes(bool on) { announcing_ = on; }
  /// The keyframes that became safe to publish since the last call, in id order. With a map
  /// file a keyframe is announced once it is committed to it (the standardisation's warm-up and
  /// the map's integrity check hold keyframes back; a crash before loses them unannounced), or
  /// once it is clear the file will not hold it (a damaged map); without one, once
  /// stored in memory; localising, once the map holds its id's reservation. A keyframe the file
  /// refused (disk full) is never announced. Keyframes the check held are committed here when it
  /// has passed meanwhile.
  std::vector<AnnouncedKeyframe> takeAnnounced();
  /// Whether stored keyframe `id` still waits for the map file to commit it (not announced yet:
  /// a crash would lose it, and its id may be given again).
  bool awaitingCommit(uint64_t id) const;

  // The detector's side: search, storing and announcing keyframes.
  /// The database's candidates (kMapDamaged, none, once the map is found damaged). Swaps in a
  /// search graph built in the background once it is ready.
  QueryResult query(const std::vector<float>& global, double stamp, const DatabaseOptions& search,
                    uint32_t session);
  /// Commits the keyframe to the map file and adds it to search (within the memory budget).
  StoredKeyframe store(KeyframeRecord keyframe);
  /// Marks `id` published in the map before its keyframe is stored (KeyframeStore's reserve);
  /// returns "" or why it could not be written.
  std::string reserveId(uint64_t id);
  /// Ids reserved at once by reserveUnstored().
  static constexpr uint64_t kUnstoredIdBlock = 256;
  /// For a keyframe published under the map's id and stored nowhere (localisation): reserves its
  /// id (a block of kUnstoredIdBlock at a time) and its session in the map, so that no later run
  /// gives either again. Returns "" or why it could not be written; announce such a keyframe
  /// with announceUnstored(), and it is released once the map holds the reservation.
  std::string reserveUnstored(uint64_t id, uint32_t session);
  /// Why the map file refuses writes now (a full disk, the map not checkable while it lasts); ""
  /// once a write has succeeded again.
  const std::string& writeProblem() const { return write_problem_; }
  /// Announces a keyframe stored elsewhere, or in this map (`wait_for_commit`: once committed).
  void announce(const KeyframeSummary& keyframe, bool wait_for_commit);
  /// Announces a keyframe stored nowhere (localising) once the map holds its id's reservation
  /// (reserveUnstored()).
  void announceUnstored(const KeyframeSummary& keyframe);

 private:
  /// Swaps the background graph in when it is ready (or, `wait`, once it is).
  void adoptBuiltGraph(bool wait);
  /// Drops a save in steps whose map is about to be replaced; its next step says so.
  void abandonSave();
  void storeHeldKeyframes() {
    if (user_) user_->storeHeldKeyframes();
  }

  Settings settings_;
  MapUser* user_;
  KeyframeDatabase database_;
  std::unique_ptr<KeyframeStore> store_;  ///< The map on disk; null: memory only.
  std::unique_ptr<MapCopy> save_;         ///< A save in steps (beginSave); before store_ dies.
  bool save_abandoned_ = false;           ///< The map was replaced during that save.
  bool graph_reused_ = false;
  std::unique_ptr<BackgroundGraph> graph_build_;  ///< See graphBuilding().
  std::vector<std::string> leftovers_removed_;
  std::vector<std::string> repairs_;
  std::string damage_;
  size_t unsearched_ = 0;
  size_t unwritten_ = 0;       ///< Keyframes store() could not write (see keyframesNotWritten).
  std::string write_problem_;  ///< See writeProblem().
  uint64_t memory_map_id_ = KeyframeStore::drawMapId();  ///< mapId() without a map file.
  /// announceKeyframes(): keyframes waiting for the map's check to commit them, and those ready.
  bool announcing_ = false;
  struct Waiting {
    AnnouncedKeyframe announced;
    bool ready = false;           ///< Settled already; waits only behind the ones before it.
    bool stored_nowhere = false;  ///< announceUnstored(): released by its id's reservation.
  };
  std::deque<Waiting> waiting_for_commit_;
  std::vector<AnnouncedKeyframe> announced_;
};

}  // namespace landmark_loop_closure
