// Every shipped config file must load into NodeOptions without unknown keys or type errors and
// validate; config/default.yaml must document every option with its built-in default.
#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/config/yaml_parameter_source.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

namespace {

std::vector<fs::path> shippedConfigs() {
  std::vector<fs::path> paths;
  for (const auto& entry :
       fs::recursive_directory_iterator(fs::path(PACKAGE_SOURCE_DIR) / "config")) {
    if (entry.path().extension() == ".yaml") paths.push_back(entry.path());
  }
  return paths;
}

}  // namespace

TEST(ShippedConfig, EveryFileLoadsAndValidates) {
  const auto paths = shippedConfigs();
  ASSERT_FALSE(paths.empty());
  for (const fs::path& path : paths) {
    SCOPED_TRACE(path.string());
    const YamlParameterSource source = YamlParameterSource::fromFile(path.string());
    OptionReader reader(source);
    NodeOptions options;
    readNodeOptions(&reader, &options);
    EXPECT_EQ(reader.errors(), "");
    EXPECT_EQ(options.validate(), "");
    for (const std::string& key : source.keys()) {
      EXPECT_TRUE(reader.isKnown(key)) << "unknown key " << key;
    }
  }
}

TEST(ShippedConfig, DefaultYamlDocumentsEveryOptionWithItsDefault) {
  const YamlParameterSource source =
      YamlParameterSource::fromFile(std::string(PACKAGE_SOURCE_DIR) + "/config/default.yaml");
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  for (const ParameterRecord& record : reader.records()) {
    EXPECT_TRUE(record.found) << record.key << " is missing from config/default.yaml";
    EXPECT_TRUE(record.equals_default)
        << record.key << " in config/default.yaml differs from the built-in default";
  }
}

TEST(YamlParameterSource, ReportsWrongTypesAndKeepsDefaults) {
  const YamlParameterSource source(
      YAML::Load("keyframe: {min_motion: fast}\nsync_queue_size: 2.5\n"));
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  EXPECT_NE(reader.errors().find("keyframe/min_motion must be a number"), std::string::npos);
  EXPECT_NE(reader.errors().find("sync_queue_size must be an integer"), std::string::npos);
  EXPECT_EQ(options.detector.keyframe.min_motion, NodeOptions{}.detector.keyframe.min_motion);
}

TEST(YamlParameterSource, MissingFileNamesThePath) {
  try {
    YamlParameterSource::fromFile("/nonexistent/params.yaml");
    FAIL() << "expected an exception";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/params.yaml"), std::string::npos);
  }
}

TEST(NodeOptions, ValidateCatchesNonsense) {
  NodeOptions options;
  options.sync_slop = 0.0;
  options.detector.acceptance.min_score = 3.0;
  const std::string errors = options.validate();
  EXPECT_NE(errors.find("sync_slop"), std::string::npos) << errors;
  EXPECT_NE(errors.find("acceptance/min_score"), std::string::npos) << errors;
}

TEST(NodeOptions, WordsBecomeEnumsWhenReadAndUnknownWordsNameTheChoices) {
  const YamlParameterSource source(YAML::Load(
      "pose_source: tf\nrelative_pose_frame: base\ntime_jump_back: reset\nmode: localization\n"
      "acceptance: {consistency_unit: metres}\n"));
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  EXPECT_EQ(reader.errors(), "");
  EXPECT_EQ(options.pose_source, PoseSource::kTf);
  EXPECT_EQ(options.relative_pose_frame, RelativePoseFrame::kBase);
  EXPECT_EQ(options.time_jump_back, TimeJumpPolicy::kReset);
  EXPECT_EQ(options.detector.mode, DetectorMode::kLocalization);
  EXPECT_EQ(options.detector.acceptance.consistency_unit, ConsistencyUnit::kMetres);

  const YamlParameterSource wrong(
      YAML::Load("pose_source: gps\nmode: relocalise\nacceptance: {consistency_unit: meters}\n"));
  OptionReader wrong_reader(wrong);
  NodeOptions kept;
  readNodeOptions(&wrong_reader, &kept);
  const std::string& errors = wrong_reader.errors();
  EXPECT_NE(errors.find("pose_source must be one of 'odom', 'tf' (got 'gps')"), std::string::npos)
      << errors;
  EXPECT_NE(errors.find("mode must be one of 'mapping', 'localization'"), std::string::npos)
      << errors;
  EXPECT_NE(errors.find("acceptance/consistency_unit must be one of 'keyframes', 'metres'"),
            std::string::npos)
      << errors;
  EXPECT_EQ(kept.pose_source, PoseSource::kOdom) << "the default stays";
}
