// Offline evaluation of loop-closure descriptors: precision-recall, recall at 100 % precision,
// AUC, timing and memory, on image folders with ground truth, or on the generated memory.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "bag_source.h"
#include "landmark_loop_closure/eval/evaluator.h"
#include "landmark_loop_closure/eval/report.h"
#include "landmark_loop_closure/eval/training.h"
#include "landmark_loop_closure/sim/sequence.h"

namespace {

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::eval;

constexpr char kUsage[] = R"(usage: lcd_evaluate SOURCE [GROUND TRUTH] [OPTIONS]

SOURCE, one of:
  --images DIR                  one sequence (images sorted by name), matched against itself
  --database DIR --queries DIR  two traversals: each query against every database image
      [--as-sequence]           ...or played one after the other as one sequence (the second
                                traversal's images then close loops with the first's)
  --corridor LAPS               the generated corridor (ground truth from its true poses)
  --bag FILE                    the keyframes a node would keep from a bag (images + odometry,
                                keyframe rule of config/default.yaml); topics: --image-topic
                                (/camera/image_raw), --odom-topic (/odom), --truth-topic (none);
                                ground truth from the truth topic's poses, else the odometry's

GROUND TRUTH, one of:
  --gt-mat FILE [--gt-var NAME] N x N matrix in a MATLAB v5 file (nonzero = same place)
  --gt-aligned N                traversals: query i is database i +- N
  --gt-poses FILE --gt-times FILE   KITTI poses; same place = within --gt-distance metres
                                (default 5), --gt-angle degrees (default 0 = any heading) and
                                at least --gt-gap seconds apart (default 30)

OPTIONS:
  --descriptors LIST   comma-separated (default pixels,hog,hog_whole): pixels, hog, hog_whole,
                       calc, landmarks, and variants of landmarks: landmarks_paper (the paper's
                       shape weighting), landmarks_conv (landmarks described by conv2 crops),
                       landmarks_conv3 (conv3 crops), landmarks_gridN (crop grid N),
                       landmarks_per_landmark (one network pass per landmark), landmarks_mN
                       (N landmarks), landmarks_wN (working width N, height 3N/4),
                       landmarks_patchN (HOG patch side), landmarks_areaP (largest box P % of
                       the image), landmarks_f32 (landmark features stored as float32)
                       cnn_pca: a CNN layer with PCA whitening (methods.md section 2; the
                       package's encoder's conv3 unless --cnn-model), variants cnn_pca_raw (no
                       whitening), cnn_pca_cosine, cnn_pca_cN (N whitened dimensions, default
                       256); broad: the broad autoencoder (section 3), broad_eN (N enhancement
                       nodes, default 2000)
                       backbone: the landmark-ConvNet on the pretrained backbone (README), variants
                       backbone_gRxC (grid), _mN (landmarks), _rP (re-rank weight P %), _hP
                       (HOG weight P %), _nW (HOG alone below W px wide), _iWxH (input), _bN
                       (layer block_N_add), _pN (landmark boxes from block_N_add), _lgN
                       (landmark grid), _hoglm (landmarks described by HOG), _pcaN (the global
                       vector PCA-whitened to N dimensions, fitted on the training images), _whole
                       / _centred
                       (grid normalisation), _paper (the paper's shape weighting)
  --model FILE         ONNX encoder for calc and landmarks (default: the package's)
  --backbone-model FILE   backbone's network (default: the package's model/mobilenet_v2.onnx)
  --cnn-model FILE --cnn-whitening FILE   cnn_pca's network (descriptor/cnn defaults otherwise)
                       and whitening; without a whitening file it is fitted on the training
                       images and written to the output folder
  --broad-model FILE   broad's model; without one it is trained on the training images
  --train-images DIR   training images of cnn_pca and broad (default: the database images, or
                       the whole sequence); no labels are used
  --top-k N            candidates a re-ranking descriptor re-scores (default 10)
  --exclude-recent N   sequence mode: the N images before a query are never matched (default 50)
  --limit N            use the first N images of each folder
  --output DIR         where results go (default lcd_results)
  --name TEXT          dataset name written into the results
  --matrix-size N      largest side of the similarity pictures (default 1000)
)";

struct Arguments {
  std::map<std::string, std::string> values;
  bool has(const std::string& key) const { return values.count(key) > 0; }
  std::string get(const std::string& key, const std::string& fallback = "") const {
    const auto it = values.find(key);
    return it == values.end() ? fallback : it->second;
  }
  double number(const std::string& key, double fallback) const {
    if (!has(key)) return fallback;
    char* end = nullptr;
    const double value = std::strtod(get(key).c_str(), &end);
    if (end == get(key).c_str() || *end != '\0') {
      throw std::invalid_argument(key + " needs a number, not '" + get(key) + "'");
    }
    return value;
  }
};

Arguments parse(int argc, char** argv) {
  Arguments arguments;
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    if (key == "--help" || key == "-h") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (key == "--as-sequence") {  // The one flag without a value.
      arguments.values[key] = "true";
      continue;
    }
    if (key.rfind("--", 0) != 0 || i + 1 >= argc) {
      throw std::invalid_argument("unexpected argument '" + key + "'");
    }
    arguments.values[key] = argv[++i];
  }
  return arguments;
}

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> items;
  std::istringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (!item.empty()) items.push_back(item);
  }
  return items;
}

// A progress line at most every few seconds, so long runs show they are alive.
Progress progressPrinter(const std::string& what) {
  auto last =
      std::make_shared<std::chrono::steady_clock::time_point>(std::chrono::steady_clock::now());
  return [what, last](size_t done, size_t total) {
    const auto now = std::chrono::steady_clock::now();
    if (done != total && now - *last < std::chrono::seconds(5)) return;
    *last = now;
    std::cerr << "lcd_evaluate: " << what << " " << done << "/" << total << "\n";
  };
}

std::vector<std::string> limited(std::vector<std::string> paths, const Arguments& arguments) {
  if (arguments.has("--limit")) {
    const size_t limit = static_cast<size_t>(arguments.number("--limit", 0));
    if (limit < paths.size()) paths.resize(limit);
  }
  return paths;
}

// A descriptor to evaluate, and how to train it when it learns from images.
struct Variant {
  DescriptorOptions options;
  int components = 256;       // cnn_pca: whitened dimensions.
  int whiten_components = 0;  // backbone_..._pcaN: the global vector whitened to N dimensions.
  BroadOptions broad;
};

// "cnn_pca_raw_cosine", "cnn_pca_c64", "broad_e10000": the methods of methods.md sections 2, 3.
Variant learnedVariant(const std::string& name, const Arguments& arguments) {
  Variant variant;
  DescriptorOptions& options = variant.options;
  const bool cnn = name.rfind("cnn_pca", 0) == 0;
  options.type = cnn ? "cnn_pca" : "broad";
  options.cnn.model = arguments.get("--cnn-model");
  options.cnn.whitening = arguments.get("--cnn-whitening");
  options.broad.model = arguments.get("--broad-model");
  std::istringstream parts(name.substr(options.type.size()));
  std::string part;
  while (std::getline(parts, part, '_')) {
    if (part.empty()) continue;
    if (cnn && part == "raw") {
      options.cnn.whitening = "none";
    } else if (cnn && part == "cosine") {
      options.cnn.similarity = "cosine";
    } else if (cnn && part.size() > 1 && part[0] == 'c' && std::isdigit(part[1])) {
      variant.components = std::stoi(part.substr(1));
    } else if (!cnn && part.size() > 1 && part[0] == 'e' && std::isdigit(part[1])) {
      variant.broad.enhancement_nodes = std::stoi(part.substr(1));
    } else {
      throw std::invalid_argument("unknown descriptor variant '" + name + "'");
    }
  }
  return variant;
}

// "backbone_g3x4_m30_r30_h20_n100_i256x144_b12_p5": the pretrained backbone with grid 3x4, 30
// landmarks, re-rank weight 0.30, HOG weight 0.20, HOG alone below 100 px wide, a 256x144 input,
// layer block_12_add, landmark boxes from block_5_add.
Variant backboneVariant(const std::string& name, const Arguments& arguments) {
  Variant variant;
  DescriptorOptions& options = variant.options;
  DescriptorOptions::Backbone& backbone = options.backbone;
  options.type = "backbone";
  backbone.model = arguments.get("--backbone-model");
  std::istringstream parts(name.substr(options.type.size()));
  std::string part;
  const auto size = [](const std::string& text, int* first, int* second) {
    const size_t x = text.find('x');
    if (x == std::string::npos) throw std::invalid_argument("expected AxB, got '" + text + "'");
    *first = std::stoi(text.substr(0, x));
    *second = std::stoi(text.substr(x + 1));
  };
  while (std::getline(parts, part, '_')) {
    if (part.empty()) continue;
    const std::string rest = part.substr(1);
    if (part == "paper") {
      options.shape_weighting = "paper";
    } else if (part.rfind("pca", 0) == 0 && part.size() > 3) {
      variant.whiten_components = std::stoi(part.substr(3));
    } else if (part == "hoglm") {
      backbone.landmark_features = "hog";
    } else if (part == "whole" || part == "centred") {
      backbone.normalisation = part;
    } else if (part.rfind("hog", 0) == 0) {
      size(part.substr(3), &backbone.hog_width, &backbone.hog_height);
    } else if (part[0] == 'g' && part.size() > 1) {
      size(rest, &backbone.grid_rows, &backbone.grid_cols);
    } else if (part[0] == 'i' && part.size() > 1) {
      size(rest, &backbone.input_width, &backbone.input_height);
    } else if (part.rfind("lg", 0) == 0) {
      backbone.landmark_grid = std::stoi(part.substr(2));
    } else if (part[0] == 'm' && part.size() > 1) {
      backbone.max_landmarks = std::stoi(rest);
    } else if (part[0] == 'r' && part.size() > 1) {
      backbone.rerank_weight = std::stoi(rest) / 100.0;
    } else if (part[0] == 'h' && part.size() > 1) {
      backbone.hog_weight = std::stoi(rest) / 100.0;
    } else if (part[0] == 'n' && part.size() > 1) {
      backbone.min_network_width = std::stoi(rest);
    } else if (part[0] == 'b' && part.size() > 1) {
      backbone.layer = "block_" + rest + "_add";
    } else if (part[0] == 'p' && part.size() > 1) {
      backbone.proposal_layer = "block_" + rest + "_add";
    } else {
      throw std::invalid_argument("unknown descriptor variant '" + name + "'");
    }
  }
  return variant;
}

// "landmarks_paper_grid2_m30" -> type landmarks, paper weighting, grid 2, 30 landmarks.
Variant descriptorVariant(const std::string& name, const Arguments& arguments) {
  if (name.rfind("cnn_pca", 0) == 0 || name.rfind("broad", 0) == 0) {
    return learnedVariant(name, arguments);
  }
  if (name.rfind("backbone", 0) == 0) return backboneVariant(name, arguments);
  Variant variant;
  DescriptorOptions& options = variant.options;
  options.model = arguments.get("--model");
  std::istringstream parts(name);
  std::getline(parts, options.type, '_');
  std::string part;
  while (std::getline(parts, part, '_')) {
    if (part == "paper") {
      options.shape_weighting = "paper";
    } else if (part == "per") {
      options.landmark_features = "conv_per_landmark";
      std::getline(parts, part, '_');  // "landmark"
    } else if (part == "conv2" || part == "conv3") {
      options.landmark_layer = part;
      options.landmark_features = "conv";
    } else if (part == "conv" || part == "hog") {
      options.landmark_features = part;
    } else if (part == "f32") {
      options.landmark_storage = "float32";
    } else if (part.rfind("w", 0) == 0 && part.size() > 1 && std::isdigit(part[1])) {
      options.working_width = std::stoi(part.substr(1));
      options.working_height = options.working_width * 3 / 4;
    } else if (part.rfind("patch", 0) == 0) {
      options.landmark_patch = std::stoi(part.substr(5));
    } else if (part.rfind("area", 0) == 0) {
      options.max_landmark_area = std::stoi(part.substr(4)) / 100.0;
    } else if (part.rfind("grid", 0) == 0) {
      options.landmark_grid = std::stoi(part.substr(4));
    } else if (part.rfind("m", 0) == 0) {
      options.max_landmarks = std::stoi(part.substr(1));
    } else if (options.type != "hog" || part != "whole") {
      throw std::invalid_argument("unknown descriptor variant '" + name + "'");
    } else {
      options.type = "hog_whole";
    }
  }
  return variant;
}

// cnn_pca without a whitening file and broad without a model learn from `training` first (no
// labels: the map's own images, as a user would train on a bag of the robot's environment); the
// result is written into the output folder and used like a user's file.
void trainWhereNeeded(Variant* variant, const std::string& name, size_t count,
                      const eval::ImageLoader& load, const std::string& output_folder) {
  DescriptorOptions& options = variant->options;
  const bool fit = options.type == "cnn_pca" && options.cnn.whitening.empty();
  const bool train = options.type == "broad" && options.broad.model.empty();
  if (!fit && !train) return;
  std::filesystem::create_directories(output_folder);
  const auto start = std::chrono::steady_clock::now();
  std::string file = output_folder + "/" + name + (fit ? ".whitening" : ".broad");
  std::string summary;
  if (fit) {
    DescriptorOptions::Cnn raw = options.cnn;
    raw.whitening = "none";
    const CnnGlobalDescriptor network(cnnGlobalOptions(raw));
    const PcaWhitening whitening =
        eval::fitWhitening(network, count, load, variant->components, 1e-3,
                           progressPrinter("fitting the whitening (" + name + ")"));
    whitening.save(file, network.featureIdentity());
    options.cnn.whitening = file;
    summary = std::to_string(whitening.inputDimension()) + " -> " +
              std::to_string(whitening.outputDimension()) + " dimensions";
  } else {
    double error = 0.0;
    const BroadModel model = eval::trainBroad(variant->broad, count, load, &error,
                                              progressPrinter("training (" + name + ")"));
    model.save(file);
    options.broad.model = file;
    summary = std::to_string(model.outputDimension()) + " output nodes, reconstruction error " +
              std::to_string(error);
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::fprintf(stderr, "lcd_evaluate: %s trained on %zu images in %.1f s (%s)\n", name.c_str(),
               count, seconds, summary.c_str());
}

struct Training {
  size_t count = 0;
  eval::ImageLoader load;
};

// A sequence held in memory (generated corridor or a bag's keyframes) with its poses.
struct MemorySequence {
  bool from_bag = false;
  std::vector<cv::Mat> images;
  std::vector<Pose> poses;
  std::vector<double> stamps;
};

int run(const Arguments& arguments) {
  const std::vector<std::string> names =
      splitList(arguments.get("--descriptors", "pixels,hog,hog_whole"));
  MatchingOptions matching;
  matching.exclude_recent = static_cast<int>(arguments.number("--exclude-recent", 50));
  matching.matrix_size = static_cast<int>(arguments.number("--matrix-size", 1000));
  matching.shortlist = static_cast<int>(arguments.number("--top-k", 10));
  RunDescription run;
  run.dataset = arguments.get("--name");
  const double gt_distance = arguments.number("--gt-distance", 5.0);
  const double gt_angle = arguments.number("--gt-angle", 0.0) * M_PI / 180.0;
  const double gt_gap = arguments.number("--gt-gap", 30.0);

  // Sources.
  std::vector<std::string> database_paths;
  std::vector<std::string> query_paths;
  size_t first_traversal = 0;  // --as-sequence: images of the first traversal.
  MemorySequence memory;
  if (arguments.has("--images")) {
    database_paths = limited(listImages(arguments.get("--images")), arguments);
    run.mode = "sequence";
  } else if (arguments.has("--database") && arguments.has("--queries")) {
    database_paths = limited(listImages(arguments.get("--database")), arguments);
    query_paths = limited(listImages(arguments.get("--queries")), arguments);
    run.mode = "traversal";
    if (arguments.has("--as-sequence")) {
      first_traversal = database_paths.size();
      database_paths.insert(database_paths.end(), query_paths.begin(), query_paths.end());
      query_paths.clear();
      run.mode = "sequence";
    }
  } else if (arguments.has("--corridor")) {
    sim::SequenceOptions options;
    options.laps = arguments.number("--corridor", 2.0);
    sim::SampledSequence sampled = sim::sampleSequence(sim::CorridorWorld{}, options, 3);
    memory.images = std::move(sampled.images);
    memory.poses = std::move(sampled.truth);
    memory.stamps = std::move(sampled.stamps);
    run.mode = "sequence";
  } else if (arguments.has("--bag")) {
    BagSourceOptions bag;
    bag.path = arguments.get("--bag");
    bag.image_topic = arguments.get("--image-topic", bag.image_topic);
    bag.odom_topic = arguments.get("--odom-topic", bag.odom_topic);
    bag.truth_topic = arguments.get("--truth-topic");
    BagKeyframes keyframes = readBagKeyframes(bag);
    std::fprintf(stderr,
                 "lcd_evaluate: %zu images, %zu keyframes (%zu without odometry within %.2f s, "
                 "%zu refused)\n",
                 keyframes.images_read, keyframes.images.size(), keyframes.images_without_odometry,
                 bag.sync_slop, keyframes.images_rejected);
    if (keyframes.keyframes_without_truth > 0) {
      std::fprintf(stderr, "lcd_evaluate: %zu keyframes had no truth pose; odometry used\n",
                   keyframes.keyframes_without_truth);
    }
    if (bag.truth_topic.empty()) {
      std::fprintf(stderr,
                   "lcd_evaluate: no --truth-topic: ground truth from the odometry, which "
                   "drifts\n");
    }
    memory.images = std::move(keyframes.images);
    memory.stamps = std::move(keyframes.stamps);
    memory.poses = bag.truth_topic.empty() ? keyframes.odometry : keyframes.truth;
    memory.from_bag = true;
    run.mode = "sequence";
  } else {
    throw std::invalid_argument("give --images, --database with --queries, --corridor or --bag");
  }
  const bool traversal = run.mode == "traversal";
  const size_t database_count =
      memory.images.empty() ? database_paths.size() : memory.images.size();
  run.database_images = database_count;
  run.query_images = traversal ? query_paths.size() : database_count;
  if (run.dataset.empty())
    run.dataset = arguments.get(
        "--images", arguments.get("--database", arguments.get("--bag", "generated corridor")));

  // Ground truth.
  GroundTruth truth;
  if (arguments.has("--gt-mat")) {
    truth = readMatGroundTruth(arguments.get("--gt-mat"), arguments.get("--gt-var"));
    run.ground_truth = arguments.get("--gt-mat");
    if (!traversal && truth.rows() == truth.cols()) truth = truth.undirected();
  } else if (arguments.has("--gt-aligned")) {
    const int tolerance = static_cast<int>(arguments.number("--gt-aligned", 0));
    if (traversal) {
      truth = alignedGroundTruth(query_paths.size(), database_paths.size(), tolerance);
    } else if (first_traversal > 0) {
      // Image first_traversal + i of the second traversal is image i of the first, +- tolerance.
      const GroundTruth across =
          alignedGroundTruth(database_paths.size() - first_traversal, first_traversal, tolerance);
      truth = GroundTruth(database_paths.size(), database_paths.size());
      for (size_t i = 0; i < across.rows(); ++i) {
        for (const uint32_t j : across.positives(i)) truth.add(first_traversal + i, j);
      }
      truth.finalize();
      truth = truth.undirected();
    } else {
      throw std::invalid_argument("--gt-aligned needs --database and --queries");
    }
    run.ground_truth = "aligned traversals, +-" + std::to_string(tolerance);
  } else if (arguments.has("--gt-poses")) {
    const std::vector<Pose> poses = readKittiPoses(arguments.get("--gt-poses"));
    const std::vector<double> stamps = readNumbers(arguments.get("--gt-times"));
    truth = poseGroundTruth(poses, stamps, gt_distance, gt_angle, gt_gap);
    run.ground_truth = arguments.get("--gt-poses");
    run.trajectory = poses;
  } else if (memory.from_bag) {
    truth = poseGroundTruth(memory.poses, memory.stamps, gt_distance, gt_angle, gt_gap);
    run.ground_truth = "bag poses: within " + std::to_string(gt_distance) + " m, " +
                       std::to_string(gt_gap) + " s apart";
    run.trajectory = memory.poses;
  } else if (!memory.images.empty()) {
    truth = poseGroundTruth(memory.poses, memory.stamps, 2.5, 45.0 * M_PI / 180.0, 20.0);
    run.ground_truth = "true poses: within 2.5 m and 45 deg, 20 s apart";
    run.trajectory = memory.poses;
  } else {
    throw std::invalid_argument("give a ground truth: --gt-mat, --gt-aligned or --gt-poses");
  }
  if (truth.rows() != run.query_images || truth.cols() != run.database_images) {
    throw GroundTruthError("the ground truth is " + std::to_string(truth.rows()) + " x " +
                           std::to_string(truth.cols()) + " but there are " +
                           std::to_string(run.query_images) + " query and " +
                           std::to_string(run.database_images) +
                           " database images (wrong file, or --limit?)");
  }

  // Training images of the learned descriptors: --train-images, else the database (traversals)
  // or the whole sequence; read in colour (each descriptor turns them grey when it wants).
  const std::string output_folder = arguments.get("--output", "lcd_results");
  Training training;
  if (arguments.has("--train-images")) {
    auto paths =
        std::make_shared<std::vector<std::string>>(listImages(arguments.get("--train-images")));
    training = {paths->size(),
                [paths](size_t i) { return cv::imread((*paths)[i], cv::IMREAD_COLOR); }};
  } else if (!memory.images.empty()) {
    training = {memory.images.size(), [&memory](size_t i) { return memory.images[i]; }};
  } else {
    training = {database_paths.size(), [&database_paths](size_t i) {
                  return cv::imread(database_paths[i], cv::IMREAD_COLOR);
                }};
  }

  std::vector<Evaluation> evaluations;
  for (const std::string& name : names) {
    Variant variant = descriptorVariant(name, arguments);
    trainWhereNeeded(&variant, name, training.count, training.load, output_folder);
    const DescriptorOptions& descriptor_options = variant.options;
    const std::string problem = descriptor_options.validate();
    if (!problem.empty()) throw std::invalid_argument(problem);
    std::shared_ptr<const DescriptorExtractor> extractor =
        makeDescriptorExtractor(descriptor_options);
    if (variant.whiten_components > 0) {
      extractor = eval::withFittedWhitening(
          extractor, training.count, training.load, variant.whiten_components,
          progressPrinter("fitting the whitening (" + name + ")"));
    }
    DescribedImages database;
    if (!memory.images.empty()) {
      database = describeImages(
          memory.images.size(), [&](size_t i) { return memory.images[i]; }, *extractor,
          progressPrinter("describing (" + name + ")"));
    } else {
      database = describeImageFiles(database_paths, *extractor,
                                    progressPrinter("describing database (" + name + ")"));
    }
    for (const std::string& path : database.undecodable) {
      std::cerr << "lcd_evaluate: skipped an image that does not decode: " << path << "\n";
    }
    Evaluation evaluation;
    if (traversal) {
      const DescribedImages queries = describeImageFiles(
          query_paths, *extractor, progressPrinter("describing queries (" + name + ")"));
      for (const std::string& path : queries.undecodable) {
        std::cerr << "lcd_evaluate: skipped an image that does not decode: " << path << "\n";
      }
      evaluation = evaluateTraversals(database, queries, truth, *extractor, matching,
                                      progressPrinter("matching (" + name + ")"));
    } else {
      evaluation = evaluateSequence(database, truth, *extractor, matching,
                                    progressPrinter("matching (" + name + ")"));
    }
    evaluation.name = name;
    const Metrics& m = evaluation.metrics;
    std::printf(
        "%-10s R@100P %.3f  AUC %.3f  AP %.3f  R@1 %.3f  describe %.2f/%.2f ms  "
        "query %.2f/%.2f ms (median/p99)  %.0f bytes/image\n",
        name.c_str(), m.recall_at_100_precision, m.auc, m.average_precision, m.recall_at_1,
        evaluation.describe_ms.median, evaluation.describe_ms.p99, evaluation.query_ms.median,
        evaluation.query_ms.p99, evaluation.bytes_per_image);
    evaluations.push_back(std::move(evaluation));
  }
  const std::string results =
      writeReport(output_folder, run, evaluations, truth, matching.matrix_size);
  std::printf("results: %s\n", results.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(parse(argc, argv));
  } catch (const std::invalid_argument& error) {
    std::cerr << "lcd_evaluate: " << error.what() << "\n\n" << kUsage;
    return 2;
  } catch (const std::exception& error) {
    std::cerr << "lcd_evaluate: error: " << error.what() << "\n";
    return 1;
  }
}
