// lcd_config: the nodelet's parameters offline.
//   lcd_config defaults          print config/default.yaml (every key, default, description)
//   lcd_config pose_graph_defaults   print config/pose_graph.yaml (the pose_graph node's)
//   lcd_config check FILE...     report unknown keys, wrong types and invalid values in
//                                parameter files, as the node would at start; exit 1 on any
#include <iostream>
#include <string>
#include <vector>

#include "command_line.h"
#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/config/yaml_parameter_source.h"

using namespace landmark_loop_closure;

namespace {

int check(const std::vector<std::string>& paths) {
  int problems = 0;
  for (const std::string& path : paths) {
    try {
      const YamlParameterSource source = YamlParameterSource::fromFile(path);
      OptionReader reader(source);
      NodeOptions options;
      readNodeOptions(&reader, &options);
      std::string report = reader.errors();
      for (const std::string& note : parameterNotes(source.keys(), reader)) report += note + "\n";
      report += options.validate();
      if (report.empty()) {
        std::cout << path << ": ok\n";
      } else {
        ++problems;
        std::cout << path << ":\n" << report;
      }
    } catch (const std::exception& error) {
      ++problems;
      std::cout << error.what() << "\n";
    }
  }
  return problems == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The nodelet's parameters offline."};
  app.require_subcommand(1);
  CLI::App* defaults = app.add_subcommand("defaults",
                                          "print config/default.yaml: every parameter, its default "
                                          "and description");
  CLI::App* pose_graph_defaults = app.add_subcommand(
      "pose_graph_defaults", "print config/pose_graph.yaml (the pose_graph node's parameters)");
  CLI::App* check_files = app.add_subcommand(
      "check",
      "read each file as the node would and report unknown keys, wrong types and invalid "
      "values; exit 1 on any");
  std::vector<std::string> paths;
  check_files->add_option("files", paths, "parameter files")->required();
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  if (*defaults) std::cout << documentedDefaultsYaml();
  if (*pose_graph_defaults) std::cout << poseGraphDefaultsYaml();
  return *check_files ? check(paths) : 0;
}
