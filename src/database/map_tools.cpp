#include "landmark_loop_closure/database/map_tools.h"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <stdexcept>

#include "database/old_map_file.h"
#include "landmark_loop_closure/database/keyframe_store.h"

namespace landmark_loop_closure {

namespace fs = std::filesystem;

namespace {

/// Writes keyframes into a map at `out` through a partial file renamed at the end, so the map
/// appears whole or not at all; memory stays flat whatever the map's size. `replace`: an existing
/// `out` is replaced, else refused.
class MapWriter {
 public:
  MapWriter(const std::string& out, const std::string& identity, int dimension,
            bool replace = false)
      : out_(out), partial_(out + ".partial") {
    if (!replace && fs::exists(out)) {
      throw std::runtime_error(out + " exists already; not overwritten");
    }
    fs::remove(partial_);
    store_ = KeyframeStore::open(partial_, identity, dimension);
  }
  ~MapWriter() {
    if (!finished_) {
      store_.reset();
      std::error_code ignored;
      fs::remove(partial_, ignored);
    }
  }
  void add(const KeyframeRecord& keyframe) { store_->add(keyframe); }
  void addAll(const KeyframeDatabase& database) { store_->addAll(database); }
  size_t finish() {
    const size_t written = store_->size();
    store_.reset();
    KeyframeStore::replaceFile(partial_, out_);
    finished_ = true;
    return written;
  }

 private:
  std::string out_;
  std::string partial_;
  std::unique_ptr<KeyframeStore> store_;
  bool finished_ = false;
};

}  // namespace

MapSummary summariseMap(const std::string& path) {
  const auto store = KeyframeStore::openExisting(path);
  MapSummary summary;
  summary.descriptor_identity = store->descriptorIdentity();
  summary.global_dimension = store->globalDimension();
  store->forEachSummary([&summary](const KeyframeSummary& keyframe, const uint8_t*, size_t) {
    ++summary.keyframes_per_session[keyframe.session];
  });
  return summary;
}

size_t writeMap(const KeyframeDatabase& database, const std::string& descriptor_identity,
                const std::string& out) {
  MapWriter writer(out, descriptor_identity, database.globalDimension(), true);
  writer.addAll(database);
  return writer.finish();
}

size_t convertMapFile(const std::string& old_file, const std::string& out) {
  std::string identity;
  int dimension = 0;
  if (!KeyframeStore::isOldMapFile(old_file)) {  // A map of the store's format 1 or 2.
    // The settings are read before the first keyframe: one keyframe in memory at a time.
    std::unique_ptr<MapWriter> writer;
    KeyframeStore::readEarlierFormat(old_file, &identity, &dimension, [&](KeyframeRecord keyframe) {
      if (!writer) writer = std::make_unique<MapWriter>(out, identity, dimension);
      writer->add(keyframe);
    });
    if (!writer) writer = std::make_unique<MapWriter>(out, identity, dimension);
    return writer->finish();
  }
  std::unique_ptr<MapWriter> writer;
  // The partial map is discarded when the file turns out corrupt at its checksum.
  readOldMapFile(
      old_file,
      [&](const OldMapFileHeader& header) {
        writer =
            std::make_unique<MapWriter>(out, header.descriptor_identity, header.global_dimension);
      },
      [&](KeyframeRecord keyframe) { writer->add(keyframe); });
  return writer->finish();
}

size_t exportSession(const std::string& map, uint32_t session, const std::string& out) {
  const auto store = KeyframeStore::openExisting(map);
  MapWriter writer(out, store->descriptorIdentity(), store->globalDimension());
  store->forEach([&](KeyframeRecord keyframe) {
    if (keyframe.session == session) writer.add(keyframe);
  });
  return writer.finish();
}

size_t mergeMaps(const std::string& out, const std::vector<std::string>& maps,
                 std::vector<uint32_t>* first_sessions) {
  if (maps.empty()) throw std::runtime_error("no maps to merge");
  std::unique_ptr<MapWriter> writer;
  std::string identity;
  uint64_t next_id = 0;
  uint32_t session_offset = 0;
  if (first_sessions) first_sessions->clear();
  for (const std::string& path : maps) {
    const auto store = KeyframeStore::openExisting(path);
    if (!writer) {
      identity = store->descriptorIdentity();
      writer = std::make_unique<MapWriter>(out, identity, store->globalDimension());
    } else if (store->descriptorIdentity() != identity) {
      throw std::runtime_error(path + " holds other descriptors (" + store->descriptorIdentity() +
                               ") than " + maps.front() + " (" + identity +
                               "): their keyframes cannot be compared");
    }
    if (first_sessions) first_sessions->push_back(session_offset);
    uint32_t last_session = 0;
    store->forEach([&](KeyframeRecord keyframe) {
      last_session = std::max(last_session, keyframe.session);
      keyframe.session += session_offset;
      keyframe.id = next_id++;
      writer->add(keyframe);
    });
    session_offset += last_session + 1;
  }
  return writer->finish();
}

}  // namespace landmark_loop_closure
