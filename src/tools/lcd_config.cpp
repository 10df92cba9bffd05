// lcd_config: the nodelet's parameters offline.
//   lcd_config defaults          print config/default.yaml (every key, default, description)
//   lcd_config pose_graph_defaults   print config/pose_graph.yaml (the pose_graph node's)
//   lcd_config check FILE...     report unknown keys, wrong types and invalid values in
//                                parameter files, as the node would at start; exit 1 on any
#include <iostream>
#include <string>

#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/config/yaml_parameter_source.h"

using namespace landmark_loop_closure;

namespace {

int usage() {
  std::cerr << "usage: lcd_config defaults | lcd_config pose_graph_defaults | lcd_config check "
               "FILE...\n"
               "  defaults: print every parameter with its default and description\n"
               "  check: read each file as the node would and report its problems\n";
  return 2;
}

int check(int argc, char** argv) {
  int problems = 0;
  for (int i = 2; i < argc; ++i) {
    const std::string path = argv[i];
    try {
      const YamlParameterSource source = YamlParameterSource::fromFile(path);
      OptionReader reader(source);
      NodeOptions options;
      readNodeOptions(&reader, &options);
      std::string report = reader.errors();
      for (const std::string& key : source.keys()) {
        if (!reader.isKnown(key)) report += key + " is not a parameter of the node\n";
      }
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
  if (argc < 2) return usage();
  const std::string command = argv[1];
  if (command == "defaults" && argc == 2) {
    std::cout << documentedDefaultsYaml();
    return 0;
  }
  if (command == "pose_graph_defaults" && argc == 2) {
    std::cout << poseGraphDefaultsYaml();
    return 0;
  }
  if (command == "check" && argc > 2) return check(argc, argv);
  return usage();
}
