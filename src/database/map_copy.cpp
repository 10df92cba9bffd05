// A copy of an open map written in steps (MapCopy), and KeyframeStore::copyTo() on top of it.
#include "landmark_loop_closure/database/map_copy.h"

#include <fcntl.h>
#include <sqlite3.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

#include "database/store_connection.h"
#include "database/vector_file.h"
#include "landmark_loop_closure/database/keyframe_store.h"

namespace landmark_loop_closure {

MapCopy::MapCopy(KeyframeStore* source, std::string target)
    : source_(source), target_(std::move(target)), partial_(target_ + ".partial") {}

MapCopy::~MapCopy() { discard(); }

void MapCopy::discard() {
  if (backup_ != nullptr) sqlite3_backup_finish(backup_);
  backup_ = nullptr;
  if (copy_ != nullptr) sqlite3_close(copy_);
  copy_ = nullptr;
  if (rows_fd_ >= 0) ::close(rows_fd_);
  rows_fd_ = -1;
  if (!finished_) {
    std::error_code ignored;
    std::filesystem::remove(partial_, ignored);
    std::filesystem::remove(partial_ + "-vectors", ignored);
  }
}

void MapCopy::fail(const std::string& what) {
  const std::string reason = copy_ != nullptr ? sqlite3_errmsg(copy_) : std::strerror(errno);
  discard();
  throw storeError(target_, what + ": " + reason);
}

bool MapCopy::step(int pages) {
  if (source_ == nullptr) return true;
  if (backup_ == nullptr) {
    switch (source_->integrityCheck()) {
      case KeyframeStore::MapCheck::kRunning:
        return false;  // Keyframes are held until it passes: the copy would lack them.
      case KeyframeStore::MapCheck::kPending:
        source_->checkIntegrity();
        break;
      case KeyframeStore::MapCheck::kDeferred:
        throw storeError(target_, "not written: the map " + source_->integrityDeferredBy());
      case KeyframeStore::MapCheck::kFailed:
      case KeyframeStore::MapCheck::kPassed:
        break;
    }
    if (source_->integrityCheck() == KeyframeStore::MapCheck::kFailed) {
      throw storeError(target_, "not written: " + source_->integrityProblem());
    }
    source_->commitHeld();
    std::error_code ignored;
    std::filesystem::remove(partial_, ignored);  // A save killed midway left it.
    if (sqlite3_open_v2(partial_.c_str(), &copy_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE,
                        nullptr) != SQLITE_OK) {
      fail("cannot be created");
    }
    // The copy's last step commits it whole: synced there it would hold the owner for as long as
    // the disk takes to write the map (0.6 s at 100 000 keyframes); finish() syncs it instead.
    if (sqlite3_exec(copy_, "PRAGMA synchronous = OFF", nullptr, nullptr, nullptr) != SQLITE_OK) {
      fail("cannot be configured");
    }
    backup_ = sqlite3_backup_init(copy_, "main", source_->connection_->db, "main");
    if (backup_ == nullptr) fail("cannot be written");
  }
  const int status = sqlite3_backup_step(backup_, pages);
  if (status == SQLITE_OK || status == SQLITE_BUSY || status == SQLITE_LOCKED) return false;
  sqlite3_backup_finish(backup_);
  backup_ = nullptr;
  if (status != SQLITE_DONE) fail("cannot be written");
  // A copy is a map of its own: the two grow apart from here, so keyframe ids repeat between them.
  const std::string copy_id = "INSERT OR REPLACE INTO meta (key, value) VALUES ('map_id', '" +
                              std::to_string(KeyframeStore::drawMapId()) + "')";
  if (sqlite3_exec(copy_, copy_id.c_str(), nullptr, nullptr, nullptr) != SQLITE_OK) {
    fail("cannot be written");
  }
  sqlite3_close(copy_);
  copy_ = nullptr;
  // Every keyframe now in the copy has its search row in the rows file (written before its
  // commit); rows written later are past what the copy uses.
  keyframes_ = source_->size();
  rows_bytes_ =
      vector_file::kHeaderBytes + keyframes_ * vector_file::entryBytes(source_->globalDimension());
  rows_fd_ = ::open(source_->vectorsPath().c_str(), O_RDONLY | O_CLOEXEC);
  if (rows_fd_ < 0 && keyframes_ > 0) fail("its search rows cannot be read");
  source_ = nullptr;
  return true;
}

void MapCopy::finish() {
  if (source_ != nullptr || finished_) {
    throw storeError(target_, "not written: the copy is not ready to finish");
  }
  if (rows_fd_ >= 0) {
    const std::string rows = partial_ + "-vectors";
    const int out = ::open(rows.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (out < 0) fail("its search rows cannot be created");
    std::vector<char> buffer(1 << 20);
    uint64_t done = 0;
    bool written = true;
    while (written && done < rows_bytes_) {
      const size_t chunk =
          static_cast<size_t>(std::min<uint64_t>(buffer.size(), rows_bytes_ - done));
      const ssize_t got = ::pread(rows_fd_, buffer.data(), chunk, static_cast<off_t>(done));
      written = got > 0 && ::write(out, buffer.data(), static_cast<size_t>(got)) == got;
      if (written) done += static_cast<uint64_t>(got);
    }
    written = written && ::fdatasync(out) == 0;
    written = ::close(out) == 0 && written;  // A tail that fails to reach the disk says so here.
    if (!written) fail("its search rows cannot be written");
    ::close(rows_fd_);
    rows_fd_ = -1;
  }
  const int database = ::open(partial_.c_str(), O_RDONLY | O_CLOEXEC);
  bool synced = database >= 0 && ::fdatasync(database) == 0;
  if (database >= 0) synced = ::close(database) == 0 && synced;
  if (!synced) fail("cannot be written to disk");
  try {
    KeyframeStore::replaceFile(partial_, target_);
  } catch (...) {
    discard();
    throw;
  }
  finished_ = true;
}

std::unique_ptr<MapCopy> KeyframeStore::startCopy(const std::string& target) {
  return std::unique_ptr<MapCopy>(new MapCopy(this, target));
}

void KeyframeStore::copyTo(const std::string& target) {
  if (awaitIntegrityCheck() == MapCheck::kFailed) {
    throw storeError(target, "not written: " + integrityProblem());
  }
  const std::unique_ptr<MapCopy> copy = startCopy(target);
  copy->step(-1);
  copy->finish();
}

}  // namespace landmark_loop_closure
