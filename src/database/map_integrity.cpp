// A map's integrity check (KeyframeStore::IntegrityCheck) and the keyframes held while it runs.
#include <sqlite3.h>

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

// What SQLite's quick_check finds wrong with the pages of the database at `path` ("" when
// nothing); nullopt when `stop` came first.
std::optional<std::string> pagesProblem(const std::string& path, const std::atomic<bool>& stop) {
  sqlite3* db = nullptr;
  const std::string uri = immutableUri(path);
  if (sqlite3_open_v2(uri.c_str(), &db, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr) !=
      SQLITE_OK) {
    const std::string reason = db != nullptr ? sqlite3_errmsg(db) : "cannot be opened";
    sqlite3_close(db);
    return "cannot be read to check it: " + reason;
  }
  sqlite3_progress_handler(
      db, 10000,
      [](void* flag) -> int { return static_cast<const std::atomic<bool>*>(flag)->load() ? 1 : 0; },
      const_cast<std::atomic<bool>*>(&stop));
  sqlite3_stmt* statement = nullptr;
  std::string problem;
  int status = sqlite3_prepare_v2(db, "PRAGMA quick_check(1)", -1, &statement, nullptr);
  if (status == SQLITE_OK) status = sqlite3_step(statement);
  if (status == SQLITE_ROW) {
    const auto* text = reinterpret_cast<const char*>(sqlite3_column_text(statement, 0));
    const std::string verdict = text != nullptr ? text : "";
    if (verdict != "ok") {
      // Its first finding, on one line ("*** in database main ***" heads the list).
      std::string line;
      for (size_t start = 0; start < verdict.size();) {
        const size_t end = std::min(verdict.find('\n', start), verdict.size());
        line = verdict.substr(start, end - start);
        if (line.rfind("***", 0) != 0) break;
        start = end + 1;
      }
      problem = "its pages are damaged (SQLite's quick_check: " + line + ")";
    }
  } else if (status == SQLITE_INTERRUPT || stop) {
    sqlite3_finalize(statement);
    sqlite3_close(db);
    return std::nullopt;
  } else {
    problem = std::string("its pages cannot be read: ") + sqlite3_errmsg(db);
  }
  sqlite3_finalize(statement);
  sqlite3_close(db);
  return problem;
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
  const std::optional<std::string> pages = pagesProblem(map_path, stop);
  if (!pages) return;
  if (!pages->empty()) {
    fail(storeError(map_path, *pages).what());
    return;
  }
  state = MapCheck::kPassed;
}

void KeyframeStore::beginIntegrityCheck() {
  check_->state = MapCheck::kRunning;
  check_->stop = false;
  // A log left by a crash goes into the file first, so the check reads what the map holds.
  sqlite3_wal_checkpoint_v2(connection_->db, nullptr, SQLITE_CHECKPOINT_TRUNCATE, nullptr, nullptr);
}

void KeyframeStore::checkIntegrity() {
  if (integrityCheck() == MapCheck::kPending) {
    beginIntegrityCheck();
    check_->run();
  }
  if (awaitIntegrityCheck() == MapCheck::kFailed) throw std::runtime_error(check_->problem());
}

void KeyframeStore::startIntegrityCheck() {
  if (integrityCheck() != MapCheck::kPending) return;
  beginIntegrityCheck();
  try {
    check_->thread = std::thread([check = check_.get()] { check->run(); });
  } catch (const std::system_error&) {
    check_->run();  // No thread to be had: checked now.
  }
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

void KeyframeStore::commitHeld() {
  saveReservation();
  if (held_.empty()) return;
  insertInOneTransaction(held_.size(), [this](size_t i) { return &held_[i]; });
  held_.clear();
}

void KeyframeStore::settleBeforeClose() {
  if (integrityCheck() != MapCheck::kRunning) {
    if (integrityCheck() == MapCheck::kPassed) commitHeld();
    return;
  }
  check_->halt();
  if (check_->state == MapCheck::kRunning) check_->state = MapCheck::kPending;
  if (integrityCheck() != MapCheck::kFailed) commitHeld();
}

}  // namespace landmark_loop_closure
