// Every shipped config file must load into NodeOptions without unknown keys or type errors and
// validate; config/default.yaml must be exactly what the parameter declarations render.
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <regex>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "landmark_loop_closure/common/text_and_files.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/config/yaml_parameter_source.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

namespace {

std::vector<fs::path> shippedConfigs() {
  std::vector<fs::path> paths;
  for (const auto& entry :
       fs::recursive_directory_iterator(fs::path(PACKAGE_SOURCE_DIR) / "config")) {
    // pose_graph*.yaml belong to the pose_graph node (test_pose_graph loads them).
    if (entry.path().extension() == ".yaml" &&
        entry.path().filename().string().rfind("pose_graph", 0) != 0) {
      paths.push_back(entry.path());
    }
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
    EXPECT_EQ(options.ignored_warning, "") << "a shipped file sets a key its descriptor ignores";
    for (const std::string& key : source.keys()) {
      EXPECT_TRUE(reader.isKnown(key)) << "unknown key " << key;
    }
  }
}

TEST(YamlParameterSource, ReportsWrongTypesAndKeepsDefaults) {
  const YamlParameterSource source(
      YAML::Load("advanced: {keyframe: {min_motion: fast}, sync_queue_size: 2.5}\n"));
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  EXPECT_NE(reader.errors().find("advanced/keyframe/min_motion must be a number"),
            std::string::npos);
  EXPECT_NE(reader.errors().find("advanced/sync_queue_size must be an integer"), std::string::npos);
  EXPECT_EQ(options.detector.keyframe.min_motion, NodeOptions{}.detector.keyframe.min_motion);
}

TEST(ShippedConfig, TheRobotBlockHasAtMostTwelveKeysEachAQuestionAndTheRestIsAdvanced) {
  std::vector<DocumentedParameter> parameters;
  NodeOptions::parameters().document(NodeOptions{}, &parameters);
  size_t robot_keys = 0, advanced_keys = 0;
  bool advanced_started = false;
  for (const DocumentedParameter& parameter : parameters) {
    if (parameter.kind != DocumentedParameter::Kind::kValue || parameter.evaluation_only) continue;
    if (parameter.key.rfind("advanced/", 0) == 0) {
      advanced_started = true;
      ++advanced_keys;
      continue;
    }
    EXPECT_FALSE(advanced_started) << parameter.key << " comes after the advanced keys";
    ++robot_keys;
    // Each robot key (or its map, for camera_mount) says which question it answers.
    const bool in_mount = parameter.key.rfind("camera_mount/", 0) == 0;
    EXPECT_TRUE(in_mount || parameter.doc.find('?') != std::string::npos) << parameter.key;
  }
  EXPECT_LE(robot_keys, 12u);
  EXPECT_GE(robot_keys, 10u);
  EXPECT_GT(advanced_keys, 50u);
  // The rendered file: the robot block first, then one `advanced:` map.
  const std::string yaml = documentedDefaultsYaml();
  EXPECT_LT(yaml.find("\ndatabase_path:"), yaml.find("\nadvanced:"));
  EXPECT_LT(yaml.find("\ncamera_mount:"), yaml.find("\nadvanced:"));
}

// A file written for the layout before `advanced/` (the user's own overrides, loaded after the
// shipped file) still loads: every moved key is read from its old name, which wins over the
// shipped value, and named with its new one.
TEST(NodeOptions, AFileOfTheEarlierLayoutStillLoadsAndEachMovedKeyIsNamed) {
  const YamlParameterSource source(
      YAML::Load("keyframe: {min_motion: 0.9}\nworker_queue_size: 20\nuse_depth: true\n"
                 "advanced: {keyframe: {min_motion: 0.2}}\nacceptance: {min_scor: 0.2}\n"));
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  EXPECT_EQ(reader.errors(), "");
  EXPECT_DOUBLE_EQ(options.detector.keyframe.min_motion, 0.9);
  EXPECT_EQ(options.worker_queue_size, 20);
  EXPECT_TRUE(options.use_depth);
  const std::vector<std::string> notes = parameterNotes(source.keys(), reader);
  const auto has = [&notes](const std::string& text) {
    return std::any_of(notes.begin(), notes.end(), [&text](const std::string& note) {
      return note.find(text) != std::string::npos;
    });
  };
  EXPECT_TRUE(has("keyframe/min_motion moved: it is now advanced/keyframe/min_motion"));
  EXPECT_TRUE(has("worker_queue_size moved: it is now advanced/worker_queue_size"));
  EXPECT_TRUE(has("acceptance/min_scor is not a parameter of the node"));
  EXPECT_EQ(notes.size(), 3u) << "use_depth kept its name; advanced/keyframe/min_motion is read";
}

// A copied default file of the earlier layout would name 150 keys at the node's start: one line
// counts them instead, while a misspelt key keeps a line of its own.
TEST(NodeOptions, TheNodeCondensesManyLayoutNotesButNamesEveryUnknownKey) {
  const YamlParameterSource source(
      YAML::Load("keyframe: {min_motion: 0.9, max_motion: 4.0}\nworker_queue_size: 20\n"
                 "verification: {orb_levels: 3}\nacceptance: {min_scor: 0.2}\n"));
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  const std::vector<std::string> notes = parameterNotes(source.keys(), reader);
  ASSERT_EQ(notes.size(), 5u);
  const std::vector<std::string> logged = condensedParameterNotes(notes);
  ASSERT_EQ(logged.size(), 2u);
  EXPECT_NE(logged[0].find("acceptance/min_scor is not a parameter"), std::string::npos);
  EXPECT_NE(logged[1].find("4 keys are of the layout before advanced/: 3 moved (read from their "
                           "old names), 1 no longer read; the first: "),
            std::string::npos)
      << logged[1];
  EXPECT_NE(logged[1].find("lcd_config check"), std::string::npos);
  EXPECT_EQ(condensedParameterNotes(notes, 10).size(), 5u) << "few enough: each its own line";
}

TEST(NodeOptions, EveryKeyOfTheEarlierDefaultFileIsNamedWhereItWent) {
  // The shipped file of before, rebuilt from today's declarations under the old names.
  std::vector<DocumentedParameter> parameters;
  NodeOptions::parameters().document(NodeOptions{}, &parameters);
  YAML::Node old_layout(YAML::NodeType::Map);
  size_t moved = 0;
  for (const DocumentedParameter& parameter : parameters) {
    if (parameter.kind != DocumentedParameter::Kind::kValue || parameter.evaluation_only) continue;
    const std::string old_name = oldParameterName(parameter.key);
    moved += old_name.empty() ? 0 : 1;
    std::vector<std::string> parts;
    std::stringstream path(old_name.empty() ? parameter.key : old_name);
    for (std::string part; std::getline(path, part, '/');) parts.push_back(part);
    std::vector<YAML::Node> chain = {old_layout};
    for (size_t i = 0; i + 1 < parts.size(); ++i) chain.push_back(chain.back()[parts[i]]);
    chain.back()[parts.back()] = YAML::Load(parameter.value);
  }
  const YamlParameterSource source(old_layout);
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  EXPECT_EQ(reader.errors(), "");
  for (const ParameterRecord& record : reader.records()) {
    EXPECT_TRUE(record.found && record.equals_default) << record.key;
  }
  const std::vector<std::string> notes = parameterNotes(source.keys(), reader);
  EXPECT_EQ(notes.size(), moved);
  for (const std::string& note : notes)
    EXPECT_NE(note.find(" moved: it is now "), std::string::npos);
}

// Keys the node keeps at their measured values: it warns and keeps the value; lcd_evaluate reads
// them, to re-measure.
TEST(NodeOptions, AFixedKeyIsNamedWithItsValueAndOnlyTheEvaluationReadsIt) {
  ASSERT_FALSE(fixedParameters().empty());
  const YamlParameterSource source(
      YAML::Load("verification: {orb_levels: 3}\nadvanced: {database: {index: {neighbors: 8}}}\n"));
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  EXPECT_EQ(reader.errors(), "");
  EXPECT_EQ(options.detector.verification.orb_levels,
            NodeOptions{}.detector.verification.orb_levels);
  EXPECT_EQ(options.detector.database.index.neighbors,
            NodeOptions{}.detector.database.index.neighbors);
  const std::vector<std::string> notes = parameterNotes(source.keys(), reader);
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_NE(notes[0].find("verification/orb_levels is no longer a parameter of the node and is "
                          "ignored: it is fixed at its measured value 1 (lcd_evaluate --config "
                          "still varies it, as advanced/verification/orb_levels)"),
            std::string::npos)
      << notes[0];
  EXPECT_NE(notes[1].find("advanced/database/index/neighbors"), std::string::npos) << notes[1];
  EXPECT_EQ(documentedDefaultsYaml().find("orb_levels"), std::string::npos);

  OptionReader evaluation(source);
  NodeOptions evaluated;
  readEvaluationOptions(&evaluation, &evaluated);
  EXPECT_EQ(evaluated.detector.verification.orb_levels, 3);
  EXPECT_EQ(evaluated.detector.database.index.neighbors, 8);
  // The earlier name is still named as moved; today's is read without a word.
  const std::vector<std::string> evaluation_notes = parameterNotes(source.keys(), evaluation);
  ASSERT_EQ(evaluation_notes.size(), 1u);
  EXPECT_NE(evaluation_notes[0].find("verification/orb_levels moved"), std::string::npos);
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
  EXPECT_NE(errors.find("advanced/acceptance/min_score"), std::string::npos) << errors;
}

TEST(NodeOptions, AReRankingDescriptorNeedsItsOwnThresholdNotTheCalibratedFloor) {
  // The calibrated decision does not apply to a re-ranked score: min_score's floor would decide
  // alone.
  NodeOptions options;
  options.detector.descriptor.type = "landmarks";
  ASSERT_GT(options.detector.acceptance.max_false_alarms, 0.0);
  const std::string errors = options.validate();
  EXPECT_NE(
      errors.find(
          "advanced/acceptance/min_score 0.1 decides alone for advanced/descriptor/type landmarks"),
      std::string::npos)
      << errors;
  options.detector.acceptance.min_score = kLandmarksMinScore;
  EXPECT_EQ(options.validate(), "");
  // The default backbone does not re-rank: the floor is a floor.
  EXPECT_EQ(NodeOptions().validate(), "");
}

TEST(NodeOptions, TheDefaultMountWithTriangulationIsWarnedAbout) {
  NodeOptions options;
  options.base_frame = "base_link";
  const std::string warning = options.defaultMountWarning();
  EXPECT_NE(warning.find("camera_mount is the default (the camera at 'base_link''s origin"),
            std::string::npos)
      << warning;
  EXPECT_NE(warning.find("advanced/camera_mount/from_tf: true"), std::string::npos) << warning;
  // Not when the mount was set, comes from tf, depths come from a depth image, or nothing is
  // triangulated.
  NodeOptions set = options;
  set.detector.camera_mount.z = 0.4;
  EXPECT_EQ(set.defaultMountWarning(), "");
  NodeOptions from_tf = options;
  from_tf.camera_mount_from_tf = true;
  EXPECT_EQ(from_tf.defaultMountWarning(), "");
  NodeOptions depth = options;
  depth.use_depth = true;
  EXPECT_EQ(depth.defaultMountWarning(), "");
  NodeOptions appearance_only = options;
  appearance_only.detector.metric_pose.triangulate_from_odometry = false;
  EXPECT_EQ(appearance_only.defaultMountWarning(), "");
}

// Issue 67 point 5: one source for the mount, tf by default where it has it. With no value set
// (and from_tf off) the detector asks tf first and falls back to the defaults; a value set, or
// from_tf, decides alone.
TEST(NodeOptions, WithNoMountValueSetTfIsAskedFirstByBothNodes) {
  NodeOptions options;
  EXPECT_TRUE(options.mountFromTfWhereKnown());
  NodeOptions set = options;
  set.detector.camera_mount.yaw = 0.0;
  EXPECT_FALSE(set.mountFromTfWhereKnown());
  NodeOptions from_tf = options;
  from_tf.camera_mount_from_tf = true;
  EXPECT_FALSE(from_tf.mountFromTfWhereKnown()) << "tf only, no fallback";
  NodeOptions no_base = options;
  no_base.base_frame.clear();
  EXPECT_FALSE(no_base.mountFromTfWhereKnown());
  // The pose graph's side: test_pose_graph_session.
}

TEST(NodeOptions, WordsBecomeEnumsWhenReadAndUnknownWordsNameTheChoices) {
  const YamlParameterSource source(
      YAML::Load("pose_source: tf\nmode: localization\nadvanced: {relative_pose_frame: base, "
                 "time_jump_back: reset}\nacceptance: {consistency_unit: metres}\n"));
  OptionReader reader(source);
  NodeOptions options;
  readEvaluationOptions(&reader, &options);  // consistency_unit: lcd_evaluate's alone.
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
  readEvaluationOptions(&wrong_reader, &kept);
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

TEST(ShippedConfig, DefaultYamlIsTheDeclaredParameters) {
  std::ifstream file(std::string(PACKAGE_SOURCE_DIR) + "/config/default.yaml");
  ASSERT_TRUE(file.good());
  const std::string shipped((std::istreambuf_iterator<char>(file)),
                            std::istreambuf_iterator<char>());
  EXPECT_EQ(shipped, documentedDefaultsYaml())
      << "config/default.yaml differs from the parameter declarations; regenerate it with\n"
         "  rosrun landmark_loop_closure lcd_config defaults > config/default.yaml";
}

TEST(ParameterTable, RangesWordsAndTextsReadBack) {
  EXPECT_EQ(between(1, 16).describe(), "in [1, 16]");
  EXPECT_EQ(openBetween(0, 1, true, false).describe(), "in (0, 1]");
  EXPECT_EQ(atLeast(0).describe(), ">= 0");
  EXPECT_FALSE(atLeast(0).contains(std::numeric_limits<double>::quiet_NaN()));
  EXPECT_FALSE(atLeast(0).contains(std::numeric_limits<double>::infinity()));
  EXPECT_TRUE(above(0).contains(1e-9));
  EXPECT_FALSE(above(0).contains(0));
  for (const double value : {0.05, 0.001, -1.5707963267948966, 33177600.0, 10.0, 1e-12}) {
    EXPECT_EQ(std::stod(yamlValueText(value)), value) << yamlValueText(value);
  }
  EXPECT_EQ(yamlValueText(10.0), "10.0");
  EXPECT_EQ(yamlValueText(std::string("0 0 0")), "\"0 0 0\"");
  EXPECT_EQ(yamlValueText(std::string("")), "\"\"");
  EXPECT_EQ(yamlValueText(std::string("true")), "\"true\"");
  EXPECT_EQ(yamlValueText(std::string("block_12_add")), "block_12_add");

  // The rendered defaults read back as the defaults, with nothing unknown.
  const YamlParameterSource source(YAML::Load(documentedDefaultsYaml()));
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  EXPECT_EQ(reader.errors(), "");
  for (const ParameterRecord& record : reader.records()) {
    EXPECT_TRUE(record.found && record.equals_default) << record.key;
  }
  for (const std::string& key : source.keys()) EXPECT_TRUE(reader.isKnown(key)) << key;
}

TEST(ParameterTable, OutOfRangeValuesAreNamedWithTheirRange) {
  NodeOptions options;
  options.detector.keyframe.min_motion = -1;
  options.detector.database.index.neighbors = 2;
  options.detector.database.index.type = "sideways";
  options.detector.camera_mount.roll = std::numeric_limits<double>::infinity();
  const std::string errors = options.validate();
  EXPECT_NE(errors.find("advanced/keyframe/min_motion must be >= 0 (got -1.0)"), std::string::npos)
      << errors;
  EXPECT_NE(errors.find("advanced/database/index/neighbors must be in [4, 128] (got 2)"),
            std::string::npos)
      << errors;
  EXPECT_NE(errors.find("advanced/database/index/type must be one of 'exact', 'approximate', "
                        "'auto' (got 'sideways')"),
            std::string::npos)
      << errors;
  EXPECT_NE(errors.find("camera_mount/roll must be a finite number (got .inf)"), std::string::npos)
      << errors;
}

TEST(ParameterTable, EveryIntegerHasAnUpperBoundThatIsEnforcedAndDocumented) {
  // Integers render without a decimal point in the documented defaults: each one's comment (its
  // line and the comment lines under it) says its range.
  std::vector<std::pair<std::string, std::string>> integers;  // Line, documentation.
  std::istringstream lines(documentedDefaultsYaml());
  bool in_integer = false;
  for (std::string line; std::getline(lines, line);) {
    const size_t first = line.find_first_not_of(' ');
    if (first == std::string::npos) continue;
    if (line[first] == '#') {
      if (in_integer && first > 0) integers.back().second += " " + line.substr(first + 1);
      continue;
    }
    in_integer = false;
    const size_t colon = line.find(": ");
    if (colon == std::string::npos) continue;
    const std::string rest = line.substr(colon + 2);
    const std::string value = rest.substr(0, rest.find_first_of(" #"));
    if (value.empty() || value.find_first_not_of("-0123456789") != std::string::npos) continue;
    integers.emplace_back(line, line);
    in_integer = true;
  }
  EXPECT_GE(integers.size(), 30u);  // The scan finds them: 35 in the file since the two tiers.
  for (const auto& [line, doc] : integers) {
    EXPECT_TRUE(std::regex_search(doc, std::regex("Allowed:\\s+in\\s+\\[-?[0-9]+,\\s+[0-9]+\\]")))
        << line;
  }
  NodeOptions options;
  options.worker_queue_size = 2000000000;
  options.detector.database.top_k = 100000;
  const std::string errors = options.validate();
  EXPECT_NE(errors.find("worker_queue_size must be in [1, 10000] (got 2000000000)"),
            std::string::npos)
      << errors;
  EXPECT_NE(errors.find("advanced/database/top_k must be in [1, 1000] (got 100000)"),
            std::string::npos)
      << errors;
}

TEST(NodeOptions, KeysTheDescriptorDoesNotReadAreWarnedAboutInOneLine) {
  const YamlParameterSource source(
      YAML::Load("advanced: {descriptor: {type: hog, model: /tmp/garbage.onnx, "
                 "condition_window: 5, cnn: {pooling: max}}}\n"));
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  EXPECT_EQ(reader.errors(), "");
  EXPECT_EQ(options.ignored_warning.rfind(
                "advanced/descriptor/type hog does not read advanced/descriptor/model, "
                "advanced/descriptor/cnn/pooling: they "
                "are set but change nothing (hog: ",
                0),
            0u)
      << options.ignored_warning;
  EXPECT_EQ(options.ignored_warning.find("condition_window"), std::string::npos);
}

TEST(NodeOptions, PathsExpandHomeAndVariablesAsAShellWould) {
  ::setenv("HOME", "/home/robot", 1);
  ::setenv("LCD_TEST_MAPS", "/data/maps", 1);
  ::unsetenv("LCD_TEST_UNSET");
  EXPECT_EQ(expandPath("~/maps/lab.db"), "/home/robot/maps/lab.db");
  EXPECT_EQ(expandPath("~"), "/home/robot");
  EXPECT_EQ(expandPath("~other/lab.db"), "~other/lab.db") << "another user's home: left alone";
  EXPECT_EQ(expandPath("$LCD_TEST_MAPS/lab.db"), "/data/maps/lab.db");
  EXPECT_EQ(expandPath("${LCD_TEST_MAPS}_old/lab.db"), "/data/maps_old/lab.db");
  EXPECT_EQ(expandPath("$LCD_TEST_UNSET/lab.db"), "$LCD_TEST_UNSET/lab.db") << "named in the error";
  EXPECT_EQ(expandPath("/plain/path$"), "/plain/path$");

  const YamlParameterSource source(
      YAML::Load("database_path: ~/maps/lab.db\nadvanced: {descriptor: {backbone: {model: "
                 "$LCD_TEST_MAPS/n.onnx}}}\n"));
  OptionReader reader(source);
  NodeOptions options;
  readNodeOptions(&reader, &options);
  EXPECT_EQ(options.database_path, "/home/robot/maps/lab.db");
  EXPECT_EQ(options.detector.descriptor.backbone.model, "/data/maps/n.onnx");
}

// Without the fetched backbone the node falls back to the package's encoder, which re-ranks:
// a score normalisation and its standardised threshold are replaced, and the warning says so.
TEST(KeyValueDifferences, NamesEachSettingThatDiffersInTheFirstTextsOrder) {
  EXPECT_EQ(keyValueDifferences("type=backbone hog_weight=0.1 min_network_width=160",
                                "type=backbone hog_weight=0.1 min_network_width=96", "the map",
                                "this node"),
            "min_network_width is 160 in the map, 96 in this node");
  EXPECT_EQ(keyValueDifferences("type=hog b=1", "type=calc condition_window=10", "A", "B"),
            "type is hog in A, calc in B; b is 1 in A, (unset) in B; condition_window is (unset) "
            "in A, 10 in B");
  EXPECT_EQ(keyValueDifferences("a=1 b=2", "a=1 b=2", "A", "B"), "");
  EXPECT_EQ(keyValueDifferences("", "", "A", "B"), "");
}

TEST(NodeOptions, BackboneFallbackDropsTheScoreNormalisationItCannotUse) {
  const fs::path empty_models = fs::temp_directory_path() / "lcd_no_backbone_models";
  fs::create_directories(empty_models);
  const char* before = std::getenv("LANDMARK_LOOP_CLOSURE_MODEL_DIR");
  const std::string kept = before ? before : "";
  setenv("LANDMARK_LOOP_CLOSURE_MODEL_DIR", empty_models.c_str(), 1);
  const YamlParameterSource source(
      YAML::Load("acceptance: {score_normalisation: z_score}\n"
                 "advanced: {acceptance: {min_score: 2.5}}\n"));
  OptionReader reader(source);
  NodeOptions options;
  readEvaluationOptions(&reader, &options);  // lcd_evaluate's: the node no longer normalises.
  EXPECT_EQ(reader.errors(), "");
  if (before) {
    setenv("LANDMARK_LOOP_CLOSURE_MODEL_DIR", kept.c_str(), 1);
  } else {
    unsetenv("LANDMARK_LOOP_CLOSURE_MODEL_DIR");
  }
  fs::remove(empty_models);
  EXPECT_EQ(options.detector.descriptor.type, "landmarks");
  EXPECT_EQ(options.detector.acceptance.score_normalisation, ScoreNormalisation::kNone);
  EXPECT_DOUBLE_EQ(options.detector.acceptance.min_score, kLandmarksMinScore);
  EXPECT_NE(options.fallback_warning.find("no score_normalisation"), std::string::npos)
      << options.fallback_warning;
  // Its threshold is for single images: the default sequences go too.
  EXPECT_EQ(options.detector.acceptance.sequence.length, 1);
  EXPECT_NE(options.fallback_warning.find("sequence_length 1"), std::string::npos)
      << options.fallback_warning;
  EXPECT_EQ(options.validate(), "");
}

TEST(NodeOptions, AScoreNormalisationWithAReRankingDescriptorIsRefused) {
  NodeOptions options;
  options.detector.descriptor.type = "backbone";
  options.detector.descriptor.backbone.rerank_weight = 0.3;
  options.detector.acceptance.score_normalisation = ScoreNormalisation::kZScore;
  EXPECT_NE(
      options.validate().find("advanced/acceptance/score_normalisation z_score normalises global"),
      std::string::npos)
      << options.validate();
  options.detector.descriptor.backbone.rerank_weight = 0.0;
  EXPECT_EQ(options.validate(), "");
}
