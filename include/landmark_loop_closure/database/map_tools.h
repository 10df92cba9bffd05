#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "landmark_loop_closure/database/keyframe_database.h"

namespace landmark_loop_closure {

/// What a map holds, for `lcd_db info`.
struct MapSummary {
  std::string descriptor_identity;
  int global_dimension = 0;
  std::map<uint32_t, size_t> keyframes_per_session;
};

/// Reads a map's settings and counts its keyframes per session (ids and globals only).
MapSummary summariseMap(const std::string& path);

/// Writes `database` as a map at `out`, replacing what was there, whole or not at all (one
/// transaction through a partial file). Throws std::runtime_error naming the file.
size_t writeMap(const KeyframeDatabase& database, const std::string& descriptor_identity,
                const std::string& out);

// Each of the following writes a new map at `out`, which must not exist, through a partial file
// renamed at the end (the map appears whole or not at all; memory stays flat), and returns the
// keyframes written. Throws std::runtime_error naming the file and the reason.

/// A map of the earlier single-file format (versions 1-3) or of the store's
/// format 1 as a map of the current format.
size_t convertMapFile(const std::string& old_file, const std::string& out);
/// One session of a map as a map of its own (ids and session numbers kept).
size_t exportSession(const std::string& map, uint32_t session, const std::string& out);
/// Several maps (robots) into one: each map's sessions follow the previous map's and ids are
/// renumbered from 0 in order; refused when their descriptors differ. `first_sessions`: where
/// each input's sessions start in the merged map.
size_t mergeMaps(const std::string& out, const std::vector<std::string>& maps,
                 std::vector<uint32_t>* first_sessions = nullptr);

}  // namespace landmark_loop_closure
