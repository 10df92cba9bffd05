#pragma once

#include <string>
#include <vector>

namespace landmark_loop_closure {

/// What an existing file's first bytes say it is, read without opening it as a database.
enum class FileStart {
  kUnreadable,  ///< Missing or cannot be read.
  kEmpty,
  kSqlite,  ///< An SQLite database (a map, or another program's).
  kOldMap,  ///< A map file of the format before the store (`lcd_db convert`).
  kOther,
};
FileStart fileStartOf(const std::string& path);

/// The files that make one map: the map itself and the companions written beside it (its search
/// rows, its search graph, its summaries) and SQLite's journals (-wal holds the last commits of
/// a map whose writer was killed): kept aside together, and none written over.
std::vector<std::string> mapFiles(const std::string& map);

/// Why a map may not be saved at `target` (a copy of the open map `live_map`, "" when none), or ""
/// when it may. Checked before anything is created, so a refused save leaves nothing behind:
/// - the open map itself under any name (same device and inode: a relative path, a symlink);
/// - anything that is not a regular file (a FIFO, a device, a directory, a socket);
/// - an existing file unless `overwrite`, and even then only a map (an SQLite file) that no
///   other process has open (a node still mapping to it);
/// - a companion file (PATH-vectors, ...) that is not a regular file, or present without its map;
/// - a folder that does not exist or cannot be written.
std::string saveTargetProblem(const std::string& target, const std::string& live_map,
                              bool overwrite);

/// Moves the map at `path` and its companions aside under a name no file has:
/// PATH.LABEL-YYYYmmddTHHMMSS (then -2, -3, ... when taken). Never writes over a file: each move
/// is a hard link to the new name, which fails on an existing name, then the old name's removal
/// (a plain rename where the file system has no hard links, after checking the name is free).
/// Returns the new name of the map. Throws std::runtime_error naming the file when the map could
/// not be moved (companions already moved are moved back).
std::string moveMapAside(const std::string& path, const std::string& label);

}  // namespace landmark_loop_closure
