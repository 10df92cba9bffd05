// Where the package's own files are found: models and documented defaults.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "landmark_loop_closure/common/model_directory.h"

namespace landmark_loop_closure {

TEST(PackageFiles, TheDefaultsAndModelsOfThisBuildAreFound) {
  const std::filesystem::path config = defaultConfigFile();
  EXPECT_EQ(config.filename(), "default.yaml");
  EXPECT_EQ(config.parent_path().filename(), "config");
  std::ifstream file(config);
  ASSERT_TRUE(file.good()) << config;
  std::string line;
  while (std::getline(file, line) && (line.empty() || line[0] == '#')) {
  }
  EXPECT_FALSE(line.empty()) << "no key in " << config;
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(modelDirectory()) /
                                      "calc_encoder.onnx.json"))
      << modelDirectory();
}

}  // namespace landmark_loop_closure
