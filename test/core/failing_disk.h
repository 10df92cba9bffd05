#pragma once

// A disk that fills up on demand, for tests, without a mount: SQLite's default file system
// wrapped (every open map goes through it) so that writes fail with SQLITE_FULL, as on a full
// disk, until it is emptied; and the package's own file writes (durable_file.h) failing the same
// way. Install it once per test process (FailingDisk::instance()).

#include <sqlite3.h>

#include <atomic>
#include <cstring>
#include <stdexcept>

#include "landmark_loop_closure/common/durable_file.h"

namespace landmark_loop_closure {
namespace test_support {

class FailingDisk {
 public:
  /// Registers the failing file system as SQLite's default (once) and returns it, not full.
  static FailingDisk& instance() {
    static FailingDisk disk;
    disk.empty();
    return disk;
  }
  /// From now on writes past `bytes` more fail (0: every write fails).
  void fillAfter(size_t bytes) {
    remaining_ = static_cast<long long>(bytes);
    WriteFaults faults;
    faults.bytes_until_full = bytes;
    setWriteFaults(faults);
  }
  /// Writes succeed again.
  void empty() {
    remaining_ = -1;
    clearWriteFaults();
  }
  bool full() const { return remaining_ == 0; }
  /// Writes SQLite was refused so far.
  long long refusedWrites() const { return refused_; }

 private:
  struct File {
    sqlite3_file base;
    sqlite3_file* real;
  };

  FailingDisk() {
    real_ = sqlite3_vfs_find(nullptr);
    if (real_ == nullptr) throw std::runtime_error("no SQLite file system");
    vfs_ = *real_;
    vfs_.zName = "failing_disk";
    vfs_.szOsFile = static_cast<int>(sizeof(File)) + real_->szOsFile;
    vfs_.pAppData = this;
    vfs_.xOpen = &FailingDisk::open;
    methods_ = sqlite3_io_methods{};
    methods_.iVersion = 3;
    methods_.xClose = [](sqlite3_file* f) {
      File* file = reinterpret_cast<File*>(f);
      const int status = file->real->pMethods->xClose(file->real);
      file->real->pMethods = nullptr;
      return status;
    };
    methods_.xRead = [](sqlite3_file* f, void* data, int amount, sqlite3_int64 offset) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xRead(real, data, amount, offset);
    };
    methods_.xWrite = [](sqlite3_file* f, const void* data, int amount, sqlite3_int64 offset) {
      if (!disk().take(amount)) return SQLITE_FULL;
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xWrite(real, data, amount, offset);
    };
    methods_.xTruncate = [](sqlite3_file* f, sqlite3_int64 size) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xTruncate(real, size);
    };
    methods_.xSync = [](sqlite3_file* f, int flags) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xSync(real, flags);
    };
    methods_.xFileSize = [](sqlite3_file* f, sqlite3_int64* size) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xFileSize(real, size);
    };
    methods_.xLock = [](sqlite3_file* f, int lock) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xLock(real, lock);
    };
    methods_.xUnlock = [](sqlite3_file* f, int lock) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xUnlock(real, lock);
    };
    methods_.xCheckReservedLock = [](sqlite3_file* f, int* out) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xCheckReservedLock(real, out);
    };
    methods_.xFileControl = [](sqlite3_file* f, int op, void* arg) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xFileControl(real, op, arg);
    };
    methods_.xSectorSize = [](sqlite3_file* f) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xSectorSize(real);
    };
    methods_.xDeviceCharacteristics = [](sqlite3_file* f) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xDeviceCharacteristics(real);
    };
    methods_.xShmMap = [](sqlite3_file* f, int region, int size, int extend, void volatile** out) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xShmMap(real, region, size, extend, out);
    };
    methods_.xShmLock = [](sqlite3_file* f, int offset, int n, int flags) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xShmLock(real, offset, n, flags);
    };
    methods_.xShmBarrier = [](sqlite3_file* f) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      real->pMethods->xShmBarrier(real);
    };
    methods_.xShmUnmap = [](sqlite3_file* f, int remove) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xShmUnmap(real, remove);
    };
    methods_.xFetch = [](sqlite3_file* f, sqlite3_int64 offset, int amount, void** out) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xFetch(real, offset, amount, out);
    };
    methods_.xUnfetch = [](sqlite3_file* f, sqlite3_int64 offset, void* at) {
      sqlite3_file* real = reinterpret_cast<File*>(f)->real;
      return real->pMethods->xUnfetch(real, offset, at);
    };
    if (sqlite3_vfs_register(&vfs_, 1) != SQLITE_OK) {
      throw std::runtime_error("the failing file system could not be registered");
    }
  }

  static FailingDisk& disk() { return *static_cast<FailingDisk*>(instanceVfs()->pAppData); }
  static sqlite3_vfs* instanceVfs() { return sqlite3_vfs_find("failing_disk"); }

  bool take(int amount) {
    long long left = remaining_.load();
    while (left >= 0) {
      if (left < amount) {
        remaining_ = 0;
        ++refused_;
        return false;
      }
      if (remaining_.compare_exchange_weak(left, left - amount)) return true;
    }
    return true;
  }

  static int open(sqlite3_vfs* vfs, const char* name, sqlite3_file* f, int flags, int* out_flags) {
    FailingDisk& self = *static_cast<FailingDisk*>(vfs->pAppData);
    File* file = reinterpret_cast<File*>(f);
    file->real = reinterpret_cast<sqlite3_file*>(file + 1);
    std::memset(file->real, 0, static_cast<size_t>(self.real_->szOsFile));
    const int status = self.real_->xOpen(self.real_, name, file->real, flags, out_flags);
    file->base.pMethods = file->real->pMethods != nullptr ? &self.methods_ : nullptr;
    return status;
  }

  sqlite3_vfs* real_ = nullptr;
  sqlite3_vfs vfs_{};
  sqlite3_io_methods methods_{};
  std::atomic<long long> remaining_{-1};
  std::atomic<long long> refused_{0};
};

}  // namespace test_support
}  // namespace landmark_loop_closure
