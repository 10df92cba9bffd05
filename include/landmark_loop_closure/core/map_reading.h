#pragma once

// Reading a map file for search, apart from the detector that will use it: a load opens and
// reads the new map beside the live one (seconds for a large map) while the worker goes on, and
// the map session only swaps it in (MapSession::adopt).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "landmark_loop_closure/database/background_graph.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/keyframe_store.h"

namespace landmark_loop_closure {

/// What reading a map needs from the detector (MapSession::readSettings, worker thread).
struct MapReadSettings {
  IndexOptions index;
  int global_dimension = 0;
  std::string descriptor_identity;
  double memory_budget_mb = 0.0;  ///< advanced/database/memory_budget_mb; 0: search the whole map.
  size_t cached_records = 16;     ///< Records kept in memory after reading (the newest first).
  /// More keyframes than this missing from the saved search graph (none saved, or a crash): the
  /// graph is built in the background (about 2 ms a keyframe) and search is exact until then.
  size_t graph_rows_built_inline = 1000;
};

/// A map opened and read for search, not yet any detector's.
struct ReadMap {
  std::unique_ptr<KeyframeStore> store;
  KeyframeDatabase database;
  std::string descriptor_identity;  ///< The settings it was read with.
  size_t keyframes = 0;             ///< In the file; database holds the searched ones.
  uint64_t last_id = 0;             ///< Of the file's last keyframe (0 when empty).
  uint32_t last_session = 0;
  bool graph_reused = false;
  /// The search graph being built (see MapReadSettings::graph_rows_built_inline); null when the
  /// database has its graph already, or builds none.
  std::unique_ptr<BackgroundGraph> graph_build{};
};

/// Opens the map at `path` (created when missing) and reads what search needs: the summaries and
/// rows within the memory budget, the saved graph (or builds one, in the background when many
/// keyframes lack it), and starts its integrity check
/// on a thread of its own. Throws std::runtime_error naming the file and the reason. Touches no
/// detector: any thread.
ReadMap readMap(const std::string& path, const MapReadSettings& settings);

/// Why `path` cannot be loaded as an existing map ("map PATH: does not exist"); "" when it is
/// there (readMap() creates a missing map, which a load must not).
std::string missingMapProblem(const std::string& path);

/// Makes `database` read the records of search's candidates from `store`, keeping the newest
/// `cached` in memory.
void readRecordsFrom(KeyframeDatabase* database, const KeyframeStore* store, size_t cached);

}  // namespace landmark_loop_closure
