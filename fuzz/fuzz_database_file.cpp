// libFuzzer target: the keyframe database loader must refuse, never crash or over-allocate, on
// any file. Run by scripts/fuzz.sh.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>

#include "landmark_loop_closure/database/database_file.h"

namespace {

// The loader takes a path: each input goes through one file in memory-backed /dev/shm.
const std::string& inputPath() {
  static const std::string path = "/dev/shm/lcd_fuzz_database_" + std::to_string(getpid());
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::FILE* file = std::fopen(inputPath().c_str(), "wb");
  if (!file) return 0;
  std::fwrite(data, 1, size, file);
  std::fclose(file);
  // Two threads: ranges of keyframes are read in parallel, as a large file is.
  const landmark_loop_closure::LoadedDatabase loaded =
      landmark_loop_closure::loadDatabase(inputPath(), "fuzz", 6, {}, 2);
  // Whatever loads must be whole: every keyframe readable.
  if (loaded.database) {
    for (size_t i = 0; i < loaded.database->size(); ++i) {
      const auto& keyframe = loaded.database->at(i);
      if (keyframe.descriptor.global.size() != 6) __builtin_trap();
    }
  }
  return 0;
}
