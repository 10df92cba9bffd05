// lcd_bench_store: SQLite (WAL) against LMDB as the keyframe store, on records of a keyframe's
// size. Each keyframe is its own committed transaction, as the node would write it; then the map
// is closed, reopened, and top-K candidate records are read at random as a query's re-rank would.
//   lcd_bench_store [--keyframes N] [--record-bytes B] [--top-k K] [--queries Q] [--dir DIR]
// Prints a markdown table: insert time per keyframe (median, p99), bytes on disk per keyframe,
// open time, and the time to read one query's K records (median, p99).
#include <lmdb.h>
#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <iostream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "command_line.h"

namespace fs = std::filesystem;

namespace {

volatile uint64_t read_sink = 0;  // Keeps the timed reads from being optimised away.

struct Settings {
  int keyframes = 20000;
  size_t record_bytes = 59000;
  int top_k = 10;
  int queries = 2000;
  fs::path dir = fs::temp_directory_path() / "lcd_bench_store";
};

struct Figures {
  std::string backend;
  std::vector<double> insert_ms;
  double open_ms = 0.0;
  std::vector<double> query_ms;
  uint64_t disk_bytes = 0;
};

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[std::min(values.size() - 1, static_cast<size_t>(p * (values.size() - 1) + 0.5))];
}

uint64_t folderBytes(const fs::path& folder) {
  uint64_t total = 0;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.is_regular_file()) total += entry.file_size();
  }
  return total;
}

/// A keyframe-sized record whose bytes are as incompressible as float descriptors.
std::vector<uint8_t> makeRecord(size_t bytes, uint64_t seed) {
  std::vector<uint8_t> record(bytes);
  std::mt19937_64 random(seed);
  for (size_t i = 0; i + 8 <= bytes; i += 8) {
    const uint64_t value = random();
    std::copy_n(reinterpret_cast<const uint8_t*>(&value), 8, record.data() + i);
  }
  return record;
}

void check(int sqlite_status, sqlite3* db, const char* what) {
  if (sqlite_status != SQLITE_OK && sqlite_status != SQLITE_DONE && sqlite_status != SQLITE_ROW) {
    throw std::runtime_error(std::string(what) + ": " + sqlite3_errmsg(db));
  }
}

void checkLmdb(int status, const char* what) {
  if (status != MDB_SUCCESS)
    throw std::runtime_error(std::string(what) + ": " + mdb_strerror(status));
}

std::vector<std::vector<int>> randomQueries(const Settings& settings) {
  std::mt19937 random(7);
  std::uniform_int_distribution<int> id(0, settings.keyframes - 1);
  std::vector<std::vector<int>> queries(settings.queries);
  for (auto& query : queries) {
    for (int k = 0; k < settings.top_k; ++k) query.push_back(id(random));
  }
  return queries;
}

Figures benchSqlite(const Settings& settings, const std::vector<std::vector<int>>& queries) {
  Figures figures;
  figures.backend = "SQLite 3 (WAL, synchronous=NORMAL)";
  const fs::path folder = settings.dir / "sqlite";
  fs::remove_all(folder);
  fs::create_directories(folder);
  const std::string path = (folder / "map.db").string();
  sqlite3* db = nullptr;
  check(sqlite3_open(path.c_str(), &db), db, "open");
  check(sqlite3_exec(db, "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;", nullptr, nullptr,
                     nullptr),
        db, "pragma");
  check(sqlite3_exec(db, "CREATE TABLE keyframes (id INTEGER PRIMARY KEY, record BLOB NOT NULL)",
                     nullptr, nullptr, nullptr),
        db, "create");
  sqlite3_stmt* insert = nullptr;
  check(sqlite3_prepare_v2(db, "INSERT INTO keyframes VALUES (?, ?)", -1, &insert, nullptr), db,
        "prepare insert");
  for (int id = 0; id < settings.keyframes; ++id) {
    const std::vector<uint8_t> record = makeRecord(settings.record_bytes, id);
    const auto start = std::chrono::steady_clock::now();
    // One statement outside an explicit transaction commits on its own.
    sqlite3_bind_int64(insert, 1, id);
    sqlite3_bind_blob(insert, 2, record.data(), static_cast<int>(record.size()), SQLITE_STATIC);
    check(sqlite3_step(insert), db, "insert");
    sqlite3_reset(insert);
    figures.insert_ms.push_back(millisecondsSince(start));
  }
  sqlite3_finalize(insert);
  sqlite3_close(db);  // The last connection checkpoints the WAL into the file.
  figures.disk_bytes = folderBytes(folder);

  const auto open_start = std::chrono::steady_clock::now();
  check(sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE, nullptr), db, "reopen");
  sqlite3_stmt* select = nullptr;
  check(sqlite3_prepare_v2(db, "SELECT record FROM keyframes WHERE id = ?", -1, &select, nullptr),
        db, "prepare select");
  figures.open_ms = millisecondsSince(open_start);
  uint64_t checksum = 0;
  for (const auto& query : queries) {
    const auto start = std::chrono::steady_clock::now();
    for (const int id : query) {
      sqlite3_bind_int64(select, 1, id);
      check(sqlite3_step(select), db, "select");
      const auto* bytes = static_cast<const uint8_t*>(sqlite3_column_blob(select, 0));
      checksum += bytes[sqlite3_column_bytes(select, 0) - 1];
      sqlite3_reset(select);
    }
    figures.query_ms.push_back(millisecondsSince(start));
  }
  sqlite3_finalize(select);
  sqlite3_close(db);
  read_sink = read_sink + checksum;
  return figures;
}

Figures benchLmdb(const Settings& settings, const std::vector<std::vector<int>>& queries) {
  Figures figures;
  figures.backend = "LMDB 0.9 (MDB_NOSYNC)";
  const fs::path folder = settings.dir / "lmdb";
  fs::remove_all(folder);
  fs::create_directories(folder);
  const auto openEnvironment = [&folder](MDB_env** env) {
    checkLmdb(mdb_env_create(env), "env create");
    checkLmdb(mdb_env_set_mapsize(*env, size_t{1} << 40), "mapsize");
    // NOSYNC: a commit reaches the page cache, so a killed process loses nothing committed (a
    // power cut may lose the last commits, as SQLite's synchronous=NORMAL may).
    checkLmdb(mdb_env_open(*env, folder.c_str(), MDB_NOSYNC, 0644), "env open");
  };
  MDB_env* env = nullptr;
  openEnvironment(&env);
  MDB_dbi dbi;
  {
    MDB_txn* txn = nullptr;
    checkLmdb(mdb_txn_begin(env, nullptr, 0, &txn), "txn");
    checkLmdb(mdb_dbi_open(txn, nullptr, MDB_INTEGERKEY, &dbi), "dbi");
    checkLmdb(mdb_txn_commit(txn), "commit");
  }
  for (int id = 0; id < settings.keyframes; ++id) {
    const std::vector<uint8_t> record = makeRecord(settings.record_bytes, id);
    size_t key_value = static_cast<size_t>(id);
    const auto start = std::chrono::steady_clock::now();
    MDB_txn* txn = nullptr;
    checkLmdb(mdb_txn_begin(env, nullptr, 0, &txn), "txn");
    MDB_val key{sizeof(key_value), &key_value};
    MDB_val value{record.size(), const_cast<uint8_t*>(record.data())};
    checkLmdb(mdb_put(txn, dbi, &key, &value, MDB_APPEND), "put");
    checkLmdb(mdb_txn_commit(txn), "commit");
    figures.insert_ms.push_back(millisecondsSince(start));
  }
  mdb_env_sync(env, 1);
  mdb_env_close(env);
  figures.disk_bytes = folderBytes(folder);

  const auto open_start = std::chrono::steady_clock::now();
  openEnvironment(&env);
  MDB_txn* read = nullptr;
  checkLmdb(mdb_txn_begin(env, nullptr, MDB_RDONLY, &read), "read txn");
  checkLmdb(mdb_dbi_open(read, nullptr, MDB_INTEGERKEY, &dbi), "dbi");
  figures.open_ms = millisecondsSince(open_start);
  uint64_t checksum = 0;
  for (const auto& query : queries) {
    const auto start = std::chrono::steady_clock::now();
    for (const int id : query) {
      size_t key_value = static_cast<size_t>(id);
      MDB_val key{sizeof(key_value), &key_value};
      MDB_val value;
      checkLmdb(mdb_get(read, dbi, &key, &value), "get");
      // The re-rank reads every byte, so each record is copied out of the map.
      std::vector<uint8_t> copy(static_cast<const uint8_t*>(value.mv_data),
                                static_cast<const uint8_t*>(value.mv_data) + value.mv_size);
      checksum += copy.empty() ? 0 : copy.back();
    }
    figures.query_ms.push_back(millisecondsSince(start));
  }
  mdb_txn_abort(read);
  mdb_env_close(env);
  read_sink = read_sink + checksum;
  return figures;
}

}  // namespace

int main(int argc, char** argv) {
  Settings settings;
  std::string dir = settings.dir.string();
  CLI::App app{"SQLite against LMDB as the keyframe store: insert, size on disk, open, reads."};
  app.add_option("--keyframes", settings.keyframes, "keyframes inserted, one commit each")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--record-bytes", settings.record_bytes, "bytes a keyframe record")
      ->capture_default_str()
      ->check(CLI::Range(size_t{8}, size_t{1} << 30));
  app.add_option("--top-k", settings.top_k, "records read a query")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--queries", settings.queries, "timed queries")->capture_default_str();
  app.add_option("--dir", dir, "scratch folder (removed at the end)")->capture_default_str();
  if (const auto exit_code = landmark_loop_closure::tools::parseCommandLine(&app, argc, argv))
    return *exit_code;
  settings.dir = dir;
  try {
    const auto queries = randomQueries(settings);
    std::printf(
        "# lcd_bench_store: %d keyframes of %zu bytes, one commit each; %d queries of %d "
        "records\n\n",
        settings.keyframes, settings.record_bytes, settings.queries, settings.top_k);
    std::printf(
        "| store | insert median (ms) | insert p99 (ms) | keyframes/s | disk per keyframe "
        "(bytes) | open (ms) | top-%d read median (ms) | p99 (ms) |\n",
        settings.top_k);
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (const auto& bench :
         {std::function<Figures()>([&] { return benchSqlite(settings, queries); }),
          std::function<Figures()>([&] { return benchLmdb(settings, queries); })}) {
      const Figures figures = bench();
      double total_ms = 0.0;
      for (const double ms : figures.insert_ms) total_ms += ms;
      std::printf("| %s | %.3f | %.3f | %.0f | %.0f | %.2f | %.3f | %.3f |\n",
                  figures.backend.c_str(), percentile(figures.insert_ms, 0.5),
                  percentile(figures.insert_ms, 0.99), 1000.0 * settings.keyframes / total_ms,
                  static_cast<double>(figures.disk_bytes) / settings.keyframes, figures.open_ms,
                  percentile(figures.query_ms, 0.5), percentile(figures.query_ms, 0.99));
      std::fflush(stdout);
    }
    fs::remove_all(settings.dir);
  } catch (const std::exception& error) {
    std::cerr << "lcd_bench_store: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
