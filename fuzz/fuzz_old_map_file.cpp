// libFuzzer target: the old map file's reader (lcd_db convert) must refuse, never crash or
// over-allocate, on any file. Run by scripts/fuzz.sh.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "database/old_map_file.h"

namespace {

// The reader takes a path: each input goes through one file in memory-backed /dev/shm.
const std::string& inputPath() {
  static const std::string path = "/dev/shm/lcd_fuzz_old_map_" + std::to_string(getpid());
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::FILE* file = std::fopen(inputPath().c_str(), "wb");
  if (!file) return 0;
  std::fwrite(data, 1, size, file);
  std::fclose(file);
  int dimension = 0;
  try {
    landmark_loop_closure::readOldMapFile(
        inputPath(),
        [&dimension](const landmark_loop_closure::OldMapFileHeader& header) {
          dimension = header.global_dimension;
        },
        [&dimension](landmark_loop_closure::KeyframeRecord keyframe) {
          // Whatever is handed on is whole.
          if (static_cast<int>(keyframe.descriptor.global.size()) != dimension) __builtin_trap();
        });
  } catch (const std::runtime_error&) {
  }
  return 0;
}
