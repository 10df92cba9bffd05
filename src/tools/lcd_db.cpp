// lcd_db: the node's maps (KeyframeStore files) offline.
//   lcd_db info MAP                     descriptors, keyframes per session
//   lcd_db convert OLD NEW              a map of the earlier single-file format, once
//   lcd_db export MAP SESSION OUT       one session as a map of its own
//   lcd_db merge OUT MAP...             several robots' maps into one: each map's sessions follow
//                                       the previous map's, ids are renumbered; descriptors
//                                       must be the same
// OUT and NEW must not exist; they appear whole or not at all.
#include <cstdio>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "landmark_loop_closure/database/map_tools.h"

using namespace landmark_loop_closure;

namespace {

int usage() {
  std::cerr << "usage: lcd_db info MAP\n"
               "       lcd_db convert OLD_FILE NEW_MAP\n"
               "       lcd_db export MAP SESSION OUT_MAP\n"
               "       lcd_db merge OUT_MAP MAP...\n";
  return 2;
}

int run(int argc, char** argv) {
  const std::string command = argv[1];
  if (command == "info" && argc == 3) {
    const MapSummary summary = summariseMap(argv[2]);
    size_t total = 0;
    for (const auto& [session, count] : summary.keyframes_per_session) total += count;
    std::printf("%s\n  descriptors: %s\n  global dimension: %d\n  keyframes: %zu\n", argv[2],
                summary.descriptor_identity.c_str(), summary.global_dimension, total);
    for (const auto& [session, count] : summary.keyframes_per_session) {
      std::printf("  session %u: %zu keyframes\n", session, count);
    }
    return 0;
  }
  if (command == "convert" && argc == 4) {
    std::printf("converted %zu keyframes from %s into %s\n", convertMapFile(argv[2], argv[3]),
                argv[2], argv[3]);
    return 0;
  }
  if (command == "export" && argc == 5) {
    const uint32_t session = static_cast<uint32_t>(std::stoul(argv[3]));
    std::printf("exported %zu keyframes of session %u into %s\n",
                exportSession(argv[2], session, argv[4]), session, argv[4]);
    return 0;
  }
  if (command == "merge" && argc >= 4) {
    const std::vector<std::string> maps(argv + 3, argv + argc);
    std::vector<uint32_t> first_sessions;
    const size_t written = mergeMaps(argv[2], maps, &first_sessions);
    for (size_t i = 0; i < maps.size(); ++i) {
      std::printf("%s: sessions from %u\n", maps[i].c_str(), first_sessions[i]);
    }
    std::printf("merged %zu keyframes into %s\n", written, argv[2]);
    return 0;
  }
  return usage();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) return usage();
  try {
    return run(argc, argv);
  } catch (const std::exception& error) {
    std::cerr << "lcd_db: " << error.what() << "\n";
    return 1;
  }
}
