// A map's integrity check (KeyframeStore::IntegrityCheck) and the keyframes held while it runs.
#include <sqlite3.h>

#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <system_error>
#include <thread>

#include "database/store_connection.h"
#include "landmark_loop_closure/database/keyframe_store.h"

namespace landmark_loop_closure {

namespace {

// An SQLite URI for `path` opened without locks or a log: the main connection holds the map's
// exclusive lock, and writes nothing to the file while the check reads it.
std::string immutableUri(const std::string& path) {
  std::string uri = "file:";
  for (const char c : std::filesystem::absolute(path).lexically_normal().string()) {
    if (c == '%' || c == '?' || c == '#') {
      static const char kHex[] = "0123456789ABCDEF";
      uri += '%';
      uri += kHex[(static_cast<unsigned char>(c) >> 4) & 0xF];
      uri += kHex[static_cast<unsigned char>(c) & 0xF];
    } else {
      uri += c;
    }
  }
  return uri + "?immutable=1";
}

// What SQLite's quick_check says of the pages of the database at `path`.
struct PagesVerdict {
  bool stopped = false;  ///< `stop` came first.
  std::string damage;    ///< What is wrong with the pages; "" when nothing.
  std::string unread;    ///< Why they could not be read (the disk, not the file); "" when read.
};

// Whether an SQLite status says the disk or the system failed, not the file's content.
bool isSystemFailure(int status) {
  switch (status & 0xFF) {
    case SQLITE_IOERR:
    case SQLITE_FULL:
    case SQLITE_CANTOPEN:
    case SQLITE_NOMEM:
      return true;
    default:
      return false;
  }
}

PagesVerdict pagesVerdict(const std::string& path, const std::atomic<bool>& stop) {
  PagesVerdict verdict;
  sqlite3* db = nullptr;
  const std::string uri = immutableUri(path);
  const int opened =
      sqlite3_open_v2(uri.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  if (opened != SQLITE_OK) {
    const std::string reason = db != nullptr ? sqlite3_errmsg(db) : "cannot be opened";
    sqlite3_close(db);
    (isSystemFailure(opened) ? verdict.unread : verdict.damage) =
        "cannot be read to check it: " + reason;
    return verdict;
  }
  sqlite3_progress_handler(
      db, 10000,
      [](void* flag) -> int { return static_cast<const std::atomic<bool>*>(flag)->load() ? 1 : 0; },
      const_cast<std::atomic<bool>*>(&stop));
  sqlite3_stmt* statement = nullptr;
  int status = sqlite3_prepare_v2(db, "PRAGMA quick_check(1)", -1, &statement, nullptr);
  if (status == SQLITE_OK) status = sqlite3_step(statement);
  if (status == SQLITE_ROW) {
    const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(statement, 0));
    const std::string found = text != nullptr ? text : "";
    if (found != "ok") {
      // Its first finding, on one line ("*** in database main ***" heads the list).
      std::string line;
      for (size_t start = 0; start < found.size();) {
        const size_t end = std::min(found.find('\n', start), found.size());
        line = found.substr(start, end - start);
        if (line.rfind("***", 0) != 0) break;
        start = end + 1;
      }
      verdict.damage = "its pages are damaged (SQLite's quick_check: " + line + ")";
    }
  } else if (status == SQLITE_INTERRUPT || stop) {
    verdict.stopped = true;
  } else {
    std::string reason = sqlite3_errmsg(db);
    if (const int system_error = sqlite3_system_errno(db); system_error != 0) {
      reason += std::string(" (") + std::strerror(system_error) + ")";
    }
    (isSystemFailure(status) ? verdict.unread : verdict.damage) =
        "its pages cannot be read: " + reason;
  }
  sqlite3_finalize(statement);
  sqlite3_close(db);
  return verdict;
}

}  // namespace

void KeyframeStore::IntegrityCheck::run() {
  if (rows) {
    const std::optional<uint32_t> crc = rows->checksum(entries, stop);
    if (!crc) return;
    if (*crc != expected) {
      fail(rows_damaged);
      return;
    }
  }
  const PagesVerdict pages = pagesVerdict(map_path, stop);
  if (pages.stopped) return;
  if (!pages.unread.empty()) {
    defer(pages.unread);
  } else if (!pages.damage.empty()) {
    fail(storeError(map_path, pages.damage).what());
  } else {
    state = MapCheck::kPassed;
  }
}

void KeyframeStore::beginIntegrityCheck(bool background) {
  check_->background = background;
  check_->stop = false;
  // A log left by a crash, or by a close that could not write it back (a full disk), goes into
  // the file first, so the check reads what the map holds. Until it has, the file alone is a mix
  // of old and new pages that only the log makes whole: checked then, an intact map would look
  // damaged.
  int log_frames = -1;
  int checkpointed = -1;
  const int status = sqlite3_wal_checkpoint_v2(connection_->db, nullptr, SQLITE_CHECKPOINT_TRUNCATE,
                                               &log_frames, &checkpointed);
  // Only the disk defers it (a full disk, an I/O error part way through the log); a checkpoint
  // that another reader holds back leaves the file as it was, consistent, and the check reads it.
  const bool disk_failed =
      (status & 0xFF) == SQLITE_FULL || (status & 0xFF) == SQLITE_IOERR ||
      (status == SQLITE_OK && log_frames > 0 && checkpointed >= 0 && checkpointed < log_frames);
  if (disk_failed) {
    std::string reason = status != SQLITE_OK ? sqlite3_errmsg(connection_->db)
                                             : "part of the log is not written back";
    if (const int system_error = sqlite3_system_errno(connection_->db); system_error != 0) {
      reason += std::string(" (") + std::strerror(system_error) + ")";
    }
    check_->defer("the map cannot be checked while its log cannot be written back into the file (" +
                  reason + "); tried again with the next keyframe");
    return;
  }
  check_->state = MapCheck::kRunning;
}

void KeyframeStore::checkIntegrity() {
  if (integrityCheck() == MapCheck::kPending) {
    beginIntegrityCheck(false);
    if (integrityCheck() == MapCheck::kRunning) check_->run();
  }
  if (awaitIntegrityCheck() == MapCheck::kFailed) throw std::runtime_error(check_->problem());
}

void KeyframeStore::startIntegrityCheck() {
  if (integrityCheck() != MapCheck::kPending) return;
  beginIntegrityCheck(true);
  if (integrityCheck() != MapCheck::kRunning) return;
  try {
    check_->thread = std::thread([check = check_.get()] { check->run(); });
  } catch (const std::system_error&) {
    check_->run();  // No thread to be had: checked now.
  }
}

bool KeyframeStore::retryDeferredCheck() {
  if (integrityCheck() != MapCheck::kDeferred) return true;
  if (std::chrono::steady_clock::now() - check_->deferred_at < std::chrono::seconds(1)) {
    return false;
  }
  if (check_->thread.joinable()) check_->thread.join();  // It deferred itself and ended.
  const bool background = check_->background;
  check_->state = MapCheck::kPending;
  if (background) {
    startIntegrityCheck();
  } else {
    try {
      checkIntegrity();
    } catch (const std::runtime_error&) {
      // kFailed: the caller refuses.
    }
  }
  return integrityCheck() != MapCheck::kDeferred;
}

KeyframeStore::MapCheck KeyframeStore::integrityCheck() const {
  return check_ ? check_->state.load() : MapCheck::kPassed;
}

KeyframeStore::MapCheck KeyframeStore::awaitIntegrityCheck() {
  if (check_ && check_->thread.joinable()) check_->thread.join();
  return integrityCheck();
}

std::string KeyframeStore::integrityProblem() const {
  return integrityCheck() == MapCheck::kFailed ? check_->problem() : "";
}

std::string KeyframeStore::integrityDeferredBy() const {
  return integrityCheck() == MapCheck::kDeferred ? check_->problem() : "";
}

void KeyframeStore::commitHeld() {
  saveReservation();
  if (held_.empty()) return;
  insertInOneTransaction(held_.size(), [this](size_t i) { return &held_[i]; });
  held_.clear();
}

void KeyframeStore::settleBeforeClose() {
  // What was held is committed unless the map was found damaged (a deferred check found nothing
  // wrong with the file: the disk may take them now).
  if (integrityCheck() != MapCheck::kRunning) {
    if (integrityCheck() != MapCheck::kFailed) commitHeld();
    return;
  }
  check_->halt();
  if (check_->state == MapCheck::kRunning) check_->state = MapCheck::kPending;
  if (integrityCheck() != MapCheck::kFailed) commitHeld();
}

}  // namespace landmark_loop_closure
