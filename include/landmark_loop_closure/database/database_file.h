#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "landmark_loop_closure/database/keyframe_database.h"

namespace landmark_loop_closure {

/// The keyframe database on disk, version 3. Little-endian throughout, whatever the host:
///   header: magic "LLCKFDB\n", u32 version, u32 byte-order mark 0x01020304, u64 payload bytes,
///           u32 CRC-32C (Castagnoli) of the payload;
///   payload: descriptor identity (descriptorIdentity()), u32 global dimension, u64 keyframes,
///           then each keyframe: id, session, stamp, pose, path, descriptor (global vector,
///           landmark boxes and features), local features (keypoints, ORB rows, image size, 3D
///           points, depth sd) and thumbnail (JPEG bytes); then the HNSW graph: its settings
///           (IndexOptions::graphIdentity(), empty when none was kept), u64 bytes and faiss's
///           serialisation of it; last the record table: u64 payload offset of each keyframe,
///           u64 offset where the graph starts, u64 keyframes - so ranges of keyframes can be
///           read on several threads.
/// Strings and vectors are a u32 count then the items; matrices are i32 rows, cols and type, then
/// the elements row by row. Versions 1 (raw thumbnails, no graph) and 2 (no record table) are
/// still read, on one thread.
constexpr uint32_t kDatabaseFileVersion = 3;

/// Writes `database` to `path` atomically: into `path`.tmp, flushed and closed, then renamed over
/// `path`, so a crash mid-write leaves the previous file whole. Returns "" on success, else why
/// (the previous file is untouched).
std::string saveDatabase(const KeyframeDatabase& database, const std::string& descriptor_identity,
                         const std::string& path);

struct LoadedDatabase {
  std::optional<KeyframeDatabase> database;  ///< Set on success.
  std::string error;                         ///< Why the file was refused, naming it.
  /// The graph `index` asks for was not in the file (other settings, older version, or none
  /// kept) and was built while loading.
  bool graph_rebuilt = false;
};

/// Reads a file written by saveDatabase. Refuses - nothing is half-loaded - a missing, truncated
/// or corrupt file (checksum), another byte order, a newer version, and a database made with
/// another descriptor identity or global dimension. Lengths inside the file are checked against
/// the bytes left before anything is allocated, so a corrupt file cannot exhaust memory.
/// `index`: the search structure wanted; a stored graph made with the same settings is reused.
/// `max_threads`: threads reading keyframes at once; 0 = one per core, fewer for a small file.
LoadedDatabase loadDatabase(const std::string& path, const std::string& descriptor_identity,
                            int global_dimension, const IndexOptions& index = {},
                            int max_threads = 0);

/// The descriptor identity and global dimension a file was written with, read without loading
/// it (for converting it); "" on success, else why it cannot be read.
std::string readDatabaseFileIdentity(const std::string& path, std::string* descriptor_identity,
                                     int* global_dimension);

}  // namespace landmark_loop_closure
