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

#include "command_line.h"
#include "landmark_loop_closure/database/map_tools.h"

using namespace landmark_loop_closure;

int main(int argc, char** argv) {
  CLI::App app{
      "The node's maps offline. OUT and NEW must not exist; they appear whole or not at all."};
  app.require_subcommand(1);
  std::string map, out;
  uint32_t session = 0;
  std::vector<std::string> maps;
  CLI::App* info = app.add_subcommand("info", "descriptors, keyframes per session");
  info->add_option("MAP", map, "the map")->required();
  CLI::App* convert =
      app.add_subcommand("convert", "a map of the earlier single-file format, once");
  convert->add_option("OLD", map, "the earlier file")->required();
  convert->add_option("NEW", out, "the new map")->required();
  CLI::App* export_session = app.add_subcommand("export", "one session as a map of its own");
  export_session->add_option("MAP", map, "the map")->required();
  export_session->add_option("SESSION", session, "the session")->required();
  export_session->add_option("OUT", out, "the new map")->required();
  CLI::App* merge = app.add_subcommand(
      "merge",
      "several robots' maps into one: each map's sessions follow the previous map's, ids "
      "are renumbered; descriptors must be the same");
  merge->add_option("OUT", out, "the new map")->required();
  merge->add_option("MAP", maps, "the maps, in order")->required();
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  try {
    if (*info) {
      const MapSummary summary = summariseMap(map);
      size_t total = 0;
      for (const auto& [number, count] : summary.keyframes_per_session) total += count;
      std::printf("%s\n  descriptors: %s\n  global dimension: %d\n  keyframes: %zu\n", map.c_str(),
                  summary.descriptor_identity.c_str(), summary.global_dimension, total);
      for (const auto& [number, count] : summary.keyframes_per_session) {
        std::printf("  session %u: %zu keyframes\n", number, count);
      }
    } else if (*convert) {
      std::printf("converted %zu keyframes from %s into %s\n", convertMapFile(map, out),
                  map.c_str(), out.c_str());
    } else if (*export_session) {
      std::printf("exported %zu keyframes of session %u into %s\n",
                  exportSession(map, session, out), session, out.c_str());
    } else if (*merge) {
      std::vector<uint32_t> first_sessions;
      const size_t written = mergeMaps(out, maps, &first_sessions);
      for (size_t i = 0; i < maps.size(); ++i) {
        std::printf("%s: sessions from %u\n", maps[i].c_str(), first_sessions[i]);
      }
      std::printf("merged %zu keyframes into %s\n", written, out.c_str());
    }
    return 0;
  } catch (const std::exception& error) {
    std::cerr << "lcd_db: " << error.what() << "\n";
    return 1;
  }
}
