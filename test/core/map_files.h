#pragma once

// Map files for the detector's map tests: where they go and what is removed with them.
#include <filesystem>
#include <string>

namespace landmark_loop_closure {
namespace test_support {

inline std::string temporaryPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("lcd_detector_" + name)).string();
}

/// A map file and what SQLite and the map leave beside it.
inline void removeMap(const std::string& path) {
  for (const char* suffix : {"", "-wal", "-shm", "-vectors", "-graph", "-summaries"}) {
    std::filesystem::remove(path + suffix);
  }
}

}  // namespace test_support
}  // namespace landmark_loop_closure
