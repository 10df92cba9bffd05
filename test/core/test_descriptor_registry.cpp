// The descriptor registry: one entry per type, found by name and by variant name, and the
// functions the node and the tools call (types, validation, identity, factory) answer from it.
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "file_bytes.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/descriptors/model_description.h"
#include "landmark_loop_closure/descriptors/registry.h"

using namespace landmark_loop_closure;
namespace fs = std::filesystem;

TEST(DescriptorRegistry, EveryTypeHasAUniqueNameASummaryAndAFactory) {
  std::set<std::string> names;
  for (const DescriptorType& type : descriptorRegistry()) {
    EXPECT_TRUE(names.insert(type.name).second) << type.name << " registered twice";
    EXPECT_FALSE(type.summary.empty()) << type.name;
    EXPECT_TRUE(static_cast<bool>(type.make)) << type.name;
    EXPECT_EQ(findDescriptorType(type.name), &type);
  }
  EXPECT_EQ(descriptorTypes().size(), descriptorRegistry().size());
  EXPECT_EQ(descriptorRegistry().front().name, DescriptorOptions{}.type) << "the default first";
  EXPECT_EQ(findDescriptorType("sift"), nullptr);
}

TEST(DescriptorRegistry, TypesWithoutModelsDescribeThroughTheFactory) {
  const cv::Mat image(120, 160, CV_8UC1, cv::Scalar(90));
  for (const char* name : {"hog", "hog_whole", "pixels"}) {
    DescriptorOptions options;
    options.type = name;
    EXPECT_EQ(options.validate(), "") << name;
    const auto extractor = makeDescriptorExtractor(options);
    ASSERT_NE(extractor, nullptr) << name;
    EXPECT_EQ(extractor->name(), name);
    EXPECT_EQ(static_cast<int>(extractor->describe(image).global.size()),
              extractor->globalDimension());
    // The condition window is part of what a map's vectors are; off, maps of before still load.
    EXPECT_EQ(descriptorIdentity(options),
              std::string("type=") + name +
                  " condition_window=" + std::to_string(DescriptorOptions{}.condition_window));
    options.condition_window = 0;
    EXPECT_EQ(descriptorIdentity(options), std::string("type=") + name);
  }
}

TEST(DescriptorRegistry, UnknownTypesAreRefusedNamingEveryKnownOne) {
  DescriptorOptions options;
  options.type = "sift";
  const std::string errors = options.validate();
  for (const DescriptorType& type : descriptorRegistry()) {
    EXPECT_NE(errors.find(type.name), std::string::npos) << errors;
  }
  EXPECT_THROW(makeDescriptorExtractor(options), std::invalid_argument);
}

TEST(DescriptorRegistry, TypeSpecificValidationComesFromTheEntry) {
  DescriptorOptions options;
  options.type = "broad";
  EXPECT_NE(options.validate().find("advanced/descriptor/broad/model is empty"), std::string::npos);
  options.type = "cnn_pca";
  options.cnn.colour = "cmyk";
  EXPECT_NE(options.validate().find("calc_encoder.onnx.json: colour"), std::string::npos);
  options.type = "backbone";
  options.backbone.colour = "cmyk";
  options.backbone.grid_rows = 40;
  const std::string errors = options.validate();
  EXPECT_NE(errors.find("mobilenet_v2.onnx.json: colour"), std::string::npos) << errors;
  EXPECT_NE(errors.find("advanced/descriptor/backbone/grid_rows"), std::string::npos) << errors;
  EXPECT_EQ(errors.find("calc_encoder.onnx.json"), std::string::npos) << errors;
}

TEST(DescriptorRegistry, KeysTheChosenTypeDoesNotReadAreNamedWhenSet) {
  using Keys = std::vector<std::string>;
  DescriptorOptions options;
  EXPECT_EQ(ignoredDescriptorParameters(options), Keys{}) << "defaults are never 'set'";
  options.model = "/tmp/garbage.onnx";  // The package's encoder: the backbone never reads it.
  options.backbone.grid_rows = 2;
  options.max_landmark_area = 0.4;  // The backbone's landmark boxes use it.
  options.condition_window = 5;
  EXPECT_EQ(ignoredDescriptorParameters(options), Keys{"advanced/descriptor/model"});
  options.type = "landmarks";
  EXPECT_EQ(ignoredDescriptorParameters(options), Keys{"advanced/descriptor/backbone/grid_rows"});
  options.type = "hog";
  EXPECT_EQ(ignoredDescriptorParameters(options),
            (Keys{"advanced/descriptor/model", "advanced/descriptor/max_landmark_area",
                  "advanced/descriptor/backbone/grid_rows"}));
  DescriptorOptions cnn;
  cnn.type = "cnn_pca";
  cnn.cnn.model = "/tmp/resnet.onnx";
  cnn.broad.model = "/tmp/broad.model";
  EXPECT_EQ(ignoredDescriptorParameters(cnn), Keys{"advanced/descriptor/broad/model"});
  cnn.type = "broad";
  EXPECT_EQ(ignoredDescriptorParameters(cnn), Keys{"advanced/descriptor/cnn/model"});
  cnn.type = "no_such_type";
  EXPECT_EQ(ignoredDescriptorParameters(cnn), Keys{}) << "validate() names an unknown type";
}

TEST(DescriptorRegistry, VariantNamesFindTheLongestTypeAndApplyEachPart) {
  ASSERT_NE(descriptorTypeOfVariant("hog_whole"), nullptr);
  EXPECT_EQ(descriptorTypeOfVariant("hog_whole")->name, "hog_whole");
  EXPECT_EQ(descriptorTypeOfVariant("hog")->name, "hog");
  EXPECT_EQ(descriptorTypeOfVariant("hogs"), nullptr);
  EXPECT_EQ(descriptorTypeOfVariant("cnn_pca_raw")->name, "cnn_pca");

  const DescriptorOptions backbone = applyDescriptorVariant("backbone_g2x3_m10_r30_b9", {});
  EXPECT_EQ(backbone.type, "backbone");
  EXPECT_EQ(backbone.backbone.grid_rows, 2);
  EXPECT_EQ(backbone.backbone.grid_cols, 3);
  EXPECT_EQ(backbone.backbone.max_landmarks, 10);
  EXPECT_DOUBLE_EQ(backbone.backbone.rerank_weight, 0.3);
  EXPECT_EQ(backbone.backbone.layer, "block_9_add");

  const DescriptorOptions per = applyDescriptorVariant("landmarks_per_landmark_m30", {});
  EXPECT_EQ(per.type, "landmarks");
  EXPECT_EQ(per.landmark_features, "conv_per_landmark");
  EXPECT_EQ(per.max_landmarks, 30);
  EXPECT_EQ(applyDescriptorVariant("cnn_pca_raw_cosine", {}).cnn.whitening, "none");

  EXPECT_THROW(applyDescriptorVariant("landmarks_landmark", {}), std::invalid_argument);
  EXPECT_THROW(applyDescriptorVariant("hog_m30", {}), std::invalid_argument);
  EXPECT_THROW(applyDescriptorVariant("sift", {}), std::invalid_argument);
  try {
    applyDescriptorVariant("backbone_zz", {});
    ADD_FAILURE() << "backbone_zz accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("'zz'"), std::string::npos) << error.what();
  }
}

TEST(DescriptorIdentity, ChangesWithEverySettingThatShapesDescriptorsAndWithTheModel) {
  DescriptorOptions defaults;
  defaults.type = "landmarks";
  const std::string identity = descriptorIdentity(defaults);
  EXPECT_EQ(identity, descriptorIdentity(defaults));
  DescriptorOptions fewer = defaults;
  fewer.max_landmarks = 20;
  EXPECT_NE(descriptorIdentity(fewer), identity);
  DescriptorOptions storage = defaults;
  storage.landmark_storage = "float32";
  EXPECT_NE(descriptorIdentity(storage), identity);
  DescriptorOptions hog = defaults;
  hog.type = "hog";
  EXPECT_NE(descriptorIdentity(hog), identity);

  // Same settings, a model file one byte different.
  const fs::path copy = fs::temp_directory_path() / "lcd_identity_model.onnx";
  std::vector<char> model = readBytes(defaultModelPath());
  ASSERT_FALSE(model.empty());
  writeBytes(copy, model);
  DescriptorOptions copied = defaults;
  copied.model = copy.string();
  EXPECT_EQ(descriptorIdentity(copied), identity);
  model.back() = static_cast<char>(model.back() ^ 1);
  writeBytes(copy, model);
  EXPECT_NE(descriptorIdentity(copied), identity);

  // The backbone: its own settings and its network's bytes.
  DescriptorOptions backbone;
  backbone.type = "backbone";
  backbone.backbone.model = copy.string();
  const std::string backbone_identity = descriptorIdentity(backbone);
  for (const auto& change : std::vector<std::function<void(DescriptorOptions::Backbone*)>>{
           [](DescriptorOptions::Backbone* b) { b->layer = "block_5_add"; },
           [](DescriptorOptions::Backbone* b) { b->grid_cols = 6; },
           [](DescriptorOptions::Backbone* b) { b->normalisation = "whole"; },
           [](DescriptorOptions::Backbone* b) { b->cell_pooling_power = 3.0; },
           [](DescriptorOptions::Backbone* b) { b->input_width = 320; },
           [](DescriptorOptions::Backbone* b) { b->max_landmarks = 10; },
           [](DescriptorOptions::Backbone* b) { b->hog_weight = 0.2; },
           [](DescriptorOptions::Backbone* b) { b->min_network_width = 0; },
           [](DescriptorOptions::Backbone* b) { b->mean = "0.5 0.5 0.5"; }}) {
    DescriptorOptions changed = backbone;
    change(&changed.backbone);
    EXPECT_NE(descriptorIdentity(changed), backbone_identity) << descriptorIdentity(changed);
  }
  model.back() = static_cast<char>(model.back() ^ 1);
  writeBytes(copy, model);
  EXPECT_NE(descriptorIdentity(backbone), backbone_identity);
  fs::remove(copy);
}

// A network's preprocessing is a property of its file: the package's two are described beside
// them with the options' defaults, and a network of one's own brings its description or is
// refused with a line saying what to write.
TEST(ModelDescription, ThePackagesNetworksAreDescribedWithTheDefaults) {
  const fs::path models = fs::path(PACKAGE_SOURCE_DIR) / "model";
  const auto backbone = readModelDescription((models / "mobilenet_v2.onnx").string());
  ASSERT_TRUE(backbone.has_value());
  const DescriptorOptions::Backbone backbone_defaults;
  EXPECT_EQ(backbone->input_width, backbone_defaults.input_width);
  EXPECT_EQ(backbone->input_height, backbone_defaults.input_height);
  EXPECT_EQ(backbone->colour, backbone_defaults.colour);
  EXPECT_EQ(backbone->mean, backbone_defaults.mean);
  EXPECT_EQ(backbone->std, backbone_defaults.std);
  EXPECT_EQ(backbone->layer, backbone_defaults.layer);
  EXPECT_EQ(backbone->proposal_layer, backbone_defaults.proposal_layer);
  const auto encoder = readModelDescription((models / "calc_encoder.onnx").string());
  ASSERT_TRUE(encoder.has_value());
  const DescriptorOptions::Cnn cnn_defaults;
  EXPECT_EQ(encoder->input_width, cnn_defaults.input_width);
  EXPECT_EQ(encoder->input_height, cnn_defaults.input_height);
  EXPECT_EQ(encoder->colour, cnn_defaults.colour);
  EXPECT_EQ(encoder->mean, cnn_defaults.mean);
  EXPECT_EQ(encoder->std, cnn_defaults.std);
  EXPECT_EQ(encoder->layer, cnn_defaults.layer);
}

TEST(ModelDescription, AnOwnNetworkBringsItsPreprocessingOrIsRefused) {
  const fs::path folder = fs::temp_directory_path() / "lcd_model_description";
  fs::create_directories(folder);
  const std::string model = (folder / "resnet50.onnx").string();
  std::ofstream(model) << "stands in for a network";
  fs::remove(model + ".json");
  DescriptorOptions options;
  options.type = "cnn_pca";
  options.cnn.model = model;
  std::string problem = applyModelDescriptions(&options);
  EXPECT_NE(problem.find(model + " has no description " + model + ".json"), std::string::npos)
      << problem;

  std::ofstream(model + ".json") << R"({"input_width": 224, "input_height": 224, "colour": "rgb",
             "mean": [0.485, 0.456, 0.406], "std": [0.229, 0.224, 0.225], "layer": "features"})";
  ASSERT_EQ(applyModelDescriptions(&options), "");
  EXPECT_EQ(options.cnn.input_width, 224);
  EXPECT_EQ(options.cnn.colour, "rgb");
  EXPECT_EQ(options.cnn.mean, "0.485 0.456 0.406");
  EXPECT_EQ(options.cnn.std, "0.229 0.224 0.225");
  EXPECT_EQ(options.cnn.layer, "features");
  EXPECT_EQ(options.validate(), "");

  for (const auto& [text, expected] : std::vector<std::pair<std::string, std::string>>{
           {R"({"input_width": 224})", "'input_height' is missing"},
           {R"({"input_width": 224, "input_height": 224, "colour": "cmyk", "mean": [0],
                "std": [1], "layer": "x"})",
            "'colour' must be rgb, bgr or grey (got 'cmyk')"},
           {R"({"input_width": 2, "input_height": 224})", "'input_width' must be a whole number"},
           {"not json at all", model + ".json"}}) {
    SCOPED_TRACE(text);
    std::ofstream(model + ".json") << text;
    DescriptorOptions broken;
    broken.type = "cnn_pca";
    broken.cnn.model = model;
    problem = applyModelDescriptions(&broken);
    EXPECT_NE(problem.find(expected), std::string::npos) << problem;
    EXPECT_NE(problem.find(model + ".json"), std::string::npos) << problem;
  }
  // A description with three means for a grey network: validate() names the file.
  std::ofstream(model + ".json") << R"({"input_width": 160, "input_height": 120, "colour": "grey",
      "mean": [0, 0, 0], "std": [1], "layer": "conv3"})";
  DescriptorOptions grey;
  grey.type = "cnn_pca";
  grey.cnn.model = model;
  ASSERT_EQ(applyModelDescriptions(&grey), "");
  EXPECT_NE(grey.validate().find(model + ".json: mean must be 1 number"), std::string::npos)
      << grey.validate();
  fs::remove_all(folder);
}
