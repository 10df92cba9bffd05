#include "landmark_loop_closure/database/map_file_safety.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <stdexcept>

namespace landmark_loop_closure {

namespace {

const char* kindOf(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string timeLabel() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof(text), "%Y%m%dT%H%M%S", &utc);
  return text;
}

bool nameTaken(const std::string& path) {
  struct stat status;
  return ::lstat(path.c_str(), &status) == 0 || errno != ENOENT;
}

// Moves `from` to `to` without ever replacing a file at `to`. False (errno set) on failure.
bool moveNoClobber(const std::string& from, const std::string& to) {
  if (::link(from.c_str(), to.c_str()) == 0) {
    if (::unlink(from.c_str()) == 0) return true;
    const int error = errno;
    ::unlink(to.c_str());
    errno = error;
    return false;
  }
  if (errno != EPERM && errno != EOPNOTSUPP && errno != EXDEV) return false;
  // No hard links here (FAT, some network shares): rename once the name is checked free.
  if (nameTaken(to)) {
    errno = EEXIST;
    return false;
  }
  return ::rename(from.c_str(), to.c_str()) == 0;
}

// The process whose lock on `file` conflicts with a write lock on [start, start + length), or 0
// (this process's own locks never conflict).
pid_t lockHolder(const std::string& file, off_t start, off_t length) {
  const int descriptor = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (descriptor < 0) return 0;
  struct flock probe {};
  probe.l_type = F_WRLCK;
  probe.l_whence = SEEK_SET;
  probe.l_start = start;
  probe.l_len = length;
  const bool asked = ::fcntl(descriptor, F_GETLK, &probe) == 0;
  ::close(descriptor);
  return asked && probe.l_type != F_UNLCK ? probe.l_pid : 0;
}

// The process that has the map at `path` open, or 0. SQLite locks bytes of the file from 1 GiB
// on (the pending and reserved bytes, then 510 shared ones): the node's store, in exclusive
// locking mode, holds them from its first write until it closes; an ordinary connection in WAL
// mode holds a read lock on the "dead man switch" byte of PATH-shm (offset 128, after the index
// header and the lock slots) while it is open.
pid_t processHoldingMap(const std::string& path) {
  constexpr off_t kPendingByte = 0x40000000;
  constexpr off_t kDeadManSwitch = 128;
  if (const pid_t holder = lockHolder(path, kPendingByte, 512)) return holder;
  return lockHolder(path + "-shm", kDeadManSwitch, 1);
}

}  // namespace

FileStart fileStartOf(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) return FileStart::kUnreadable;
  char header[16] = {};
  file.read(header, sizeof(header));
  const size_t read = static_cast<size_t>(file.gcount());
  if (read == 0) return FileStart::kEmpty;
  static const char kSqliteHeader[16] = "SQLite format 3";  // And its terminating zero.
  if (read == sizeof(header) && std::memcmp(header, kSqliteHeader, sizeof(header)) == 0) {
    return FileStart::kSqlite;
  }
  if (read >= 8 && std::memcmp(header, "LLCKFDB\n", 8) == 0) return FileStart::kOldMap;
  return FileStart::kOther;
}

std::vector<std::string> mapFiles(const std::string& map) {
  // The journals too: a map whose writer was killed keeps its last commits in its -wal until it
  // is next opened, so the map without it is not the map.
  return {map,          map + "-vectors", map + "-graph",  map + "-summaries",
          map + "-wal", map + "-shm",     map + "-journal"};
}

std::string saveTargetProblem(const std::string& target, const std::string& live_map,
                              bool overwrite) {
  if (target.empty()) return "no path given";
  struct stat status;
  const bool exists = ::stat(target.c_str(), &status) == 0;
  if (!exists && errno != ENOENT) {
    return target + ": " + std::strerror(errno);
  }
  if (exists && !live_map.empty()) {
    struct stat live;
    if (::stat(live_map.c_str(), &live) == 0 && live.st_dev == status.st_dev &&
        live.st_ino == status.st_ino) {
      return target + " is the open map itself (" + live_map +
             "); save without a path to commit it";
    }
  }
  if (exists) {
    if (!S_ISREG(status.st_mode)) {
      return target + " is " + kindOf(status.st_mode) + ", not a map file; nothing was written";
    }
    if (!overwrite) {
      return target +
             " exists; nothing was written (ask with overwrite to replace it: the old "
             "map is then kept under a new name)";
    }
    if (fileStartOf(target) != FileStart::kSqlite) {
      return target + " exists and is not a map; it is never replaced";
    }
    if (const pid_t holder = processHoldingMap(target)) {
      return target + " is open in another process (pid " + std::to_string(holder) +
             "), which is still writing it; nothing was written (stop it first)";
    }
  }
  const std::vector<std::string> files = mapFiles(target);
  for (size_t i = 1; i < files.size(); ++i) {
    struct stat companion;
    if (::lstat(files[i].c_str(), &companion) != 0) continue;
    if (!S_ISREG(companion.st_mode)) {
      return files[i] + " is " + std::string(kindOf(companion.st_mode)) +
             "; a map beside it would write there";
    }
    if (!exists) {
      return files[i] + " exists without its map " + target +
             "; move it away first (a new map beside it would replace it)";
    }
  }
  std::filesystem::path folder = std::filesystem::path(target).parent_path();
  if (folder.empty()) folder = ".";
  struct stat folder_status;
  if (::stat(folder.c_str(), &folder_status) != 0 || !S_ISDIR(folder_status.st_mode)) {
    return target + ": its folder " + folder.string() + " does not exist";
  }
  if (::access(folder.c_str(), W_OK) != 0) {
    return target + ": its folder " + folder.string() +
           " cannot be written: " + std::strerror(errno);
  }
  return "";
}

std::string moveMapAside(const std::string& path, const std::string& label) {
  const std::vector<std::string> files = mapFiles(path);
  const std::string stem = path + "." + label + "-" + timeLabel();
  std::string kept;
  for (int attempt = 1;; ++attempt) {
    kept = attempt == 1 ? stem : stem + "-" + std::to_string(attempt);
    bool free = true;
    for (const std::string& file : mapFiles(kept)) free = free && !nameTaken(file);
    if (free) break;
    if (attempt > 10000) throw std::runtime_error(path + ": no free name to keep it under");
  }
  const std::vector<std::string> targets = mapFiles(kept);
  std::vector<size_t> moved;
  // Companions first: the map without its rows would not open; rows without the map are inert.
  for (size_t i = files.size(); i-- > 0;) {
    if (!nameTaken(files[i])) continue;
    if (moveNoClobber(files[i], targets[i])) {
      moved.push_back(i);
      continue;
    }
    const std::string reason = std::strerror(errno);
    for (const size_t undo : moved) moveNoClobber(targets[undo], files[undo]);
    throw std::runtime_error("the map " + path + " could not be kept aside as " + kept + " (" +
                             files[i] + ": " + reason + ")");
  }
  return kept;
}

}  // namespace landmark_loop_closure
