// Offline evaluation of loop-closure descriptors and of the whole detector: precision-recall,
// recall at 100 % precision, AUC, timing and memory, on image folders with ground truth, bags,
// or the generated corridor.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "bag/bag_source.h"
#include "evaluate_detector.h"
#include "evaluate_support.h"
#include "landmark_loop_closure/eval/evaluator.h"
#include "landmark_loop_closure/eval/match_verification.h"
#include "landmark_loop_closure/eval/report.h"
#include "landmark_loop_closure/eval/training.h"
#include "landmark_loop_closure/sim/sequence.h"
#include "lcd_evaluate_usage.h"

namespace {

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::eval;
using namespace landmark_loop_closure::tools;

// Parses the command line into `arguments`; returns the code main returns at once, if any.
std::optional<int> parse(int argc, char** argv, Arguments* arguments) {
  CLI::App app{
      "Offline evaluation of loop-closure descriptors and of the whole detector: precision-recall, "
      "recall at 100 % precision, AUC, timing and memory, on image folders with ground truth, "
      "bags, or the generated corridor."};
  addTextOptions(&app, kEvaluateOptions, &arguments->values);
  app.footer(kEvaluateDetails);
  return parseCommandLine(&app, argc, argv);
}

// A sequence held in memory (generated corridor or a bag's keyframes) with its poses.
struct MemorySequence {
  bool from_bag = false;
  std::vector<cv::Mat> images;
  std::vector<Pose> poses;
  std::vector<double> stamps;
};

// Image i as the evaluation reads it: from the sequence in memory, else from `paths`.
std::function<cv::Mat(size_t)> imageLoader(const MemorySequence& memory,
                                           const std::vector<std::string>& paths, int width) {
  return [&memory, &paths, width](size_t i) -> cv::Mat {
    if (!memory.images.empty()) return i < memory.images.size() ? memory.images[i] : cv::Mat();
    return i < paths.size() ? readImage(paths[i], true, width) : cv::Mat();
  };
}

// --camera-info, checked against the first image as the node checks camera_info against its
// images: another camera's calibration would skew every geometric check, so it stops the run.
CameraIntrinsics cameraInfoFor(const Arguments& arguments, const cv::Mat& first_image) {
  if (!arguments.has("--camera-info")) return {};
  const std::string path = arguments.get("--camera-info");
  CameraIntrinsics intrinsics = readCameraInfoFile(path);
  if (const auto problem = intrinsics.checkFor(first_image.size())) {
    throw std::invalid_argument("--camera-info " + path + ": " + problem->text);
  }
  return intrinsics;
}

// --appearance-check: the node's checks on every best match, then the measures again.
void checkMatches(Evaluation* evaluation, const DescriptorExtractor& extractor,
                  const MatchChecks& checks, const std::function<cv::Mat(size_t)>& query_image,
                  const std::function<cv::Mat(size_t)>& database_image) {
  const MatchVerificationSummary summary =
      verifyMatches(&evaluation->outcomes, query_image, database_image, extractor, checks);
  evaluation->metrics = computeMetrics(evaluation->outcomes);
  std::ostringstream text;
  if (summary.checked == 0) {
    text << "nothing checked (no camera intrinsics, and no feature-map cells or the appearance "
            "check off)";
  } else {
    // The node publishes confirmed matches only: of the right best matches, the share it can
    // publish, and the wrong ones it would publish.
    const size_t right = summary.confirmed_correct + summary.refused_correct;
    text << summary.checked << " best matches checked (";
    if (checks.runsGeometry()) {
      text << "ORB min_inliers " << checks.geometry.min_inliers << ", then ";
    }
    if (checks.appearance.enabled) {
      text << "appearance min_inliers " << checks.appearance.min_inliers;
    } else {
      text << "appearance check off";
    }
    text << "): confirmed " << summary.confirmed_correct << " of " << right << " right ("
         << std::fixed << std::setprecision(3)
         << (right > 0 ? static_cast<double>(summary.confirmed_correct) / right : 0.0) << ") and "
         << summary.confirmed_wrong << " of " << summary.checked - right << " wrong";
    if (checks.runsGeometry()) text << ", " << summary.confirmed_by_geometry << " of them by ORB";
    text << "; the " << summary.refused << " refused ranked below the rest";
  }
  if (summary.checked > 0 && summary.unverifiable > 0) {
    text << "; " << summary.unverifiable << " left as they are (no check could run)";
  }
  evaluation->match_checks = text.str();
  std::printf("%-10s checks: %s\n", evaluation->name.c_str(), text.str().c_str());
}

int run(const Arguments& arguments) {
  const std::string output_folder = arguments.get("--output", "lcd_results");
  const double gt_distance = arguments.number("--gt-distance", 5.0);
  const int image_width = static_cast<int>(arguments.number("--image-width", 0));
  const int condition_window = static_cast<int>(arguments.number("--condition-window", 0));
  if (image_width < 0 || image_width > 8192) {
    throw std::invalid_argument("--image-width must be between 1 and 8192 px (0: as read)");
  }
  const double gt_gap = arguments.number("--gt-gap", 30.0);
  if (arguments.has("--detector") && arguments.has("--corridor")) {
    CorridorRun run;
    run.aliasing = arguments.has("--aliasing");
    run.protocol = runProtocol(arguments.get("--protocol", "one-sequence"));
    run.odometry_jump_at_laps = arguments.number("--odometry-jump-at", 0.0);
    return runDetectorMode(arguments, corridorSource(arguments.number("--corridor", 2.0), run),
                           arguments.get("--name", run.aliasing ? "generated aliasing corridor"
                                                                : "generated corridor"),
                           output_folder);
  }
  if (arguments.has("--detector") && arguments.has("--bag")) {
    return runDetectorMode(
        arguments,
        bagSource(arguments.get("--bag"), arguments.get("--image-topic", "/camera/image_raw"),
                  arguments.get("--odom-topic", "/odom"), arguments.get("--truth-topic"),
                  gt_distance, gt_gap),
        arguments.get("--name", arguments.get("--bag")), output_folder);
  }
  if (arguments.has("--detector") && arguments.has("--queries") &&
      !arguments.has("--as-sequence")) {
    throw std::invalid_argument("--detector plays one sequence: add --as-sequence");
  }
  const bool no_truth = arguments.has("--no-ground-truth");
  if (no_truth && arguments.has("--detector")) {
    throw std::invalid_argument("--detector scores published loops: it needs a ground truth");
  }
  const std::vector<std::string> names =
      splitList(arguments.get("--descriptors", "backbone,pixels,hog,hog_whole"));
  MatchingOptions matching;
  matching.exclude_recent = static_cast<int>(arguments.number("--exclude-recent", 50));
  matching.matrix_size = static_cast<int>(arguments.number("--matrix-size", 1000));
  matching.shortlist = static_cast<int>(arguments.number("--top-k", 10));
  RunDescription run;
  run.dataset = arguments.get("--name");
  const double gt_angle = arguments.number("--gt-angle", 0.0) * M_PI / 180.0;

  // Sources.
  std::vector<std::string> database_paths;
  std::vector<std::string> query_paths;
  size_t first_traversal = 0;     // --as-sequence: images of the first traversal.
  std::vector<bool> joint_stops;  // --gt-stops: frames where both traversals stand.
  MemorySequence memory;
  const auto list = [&arguments](const std::string& key) {
    std::vector<std::string> paths = listImages(arguments.get(key));
    if (textOrderDiffers(paths)) {
      std::fprintf(
          stderr,
          "lcd_evaluate: warning: %s: file names sorted with their numbers as numbers "
          "(%s, %s, ...), which differs from plain text order; the ground truth must "
          "follow this order\n",
          arguments.get(key).c_str(), std::filesystem::path(paths[0]).filename().c_str(),
          std::filesystem::path(paths[std::min<size_t>(1, paths.size() - 1)]).filename().c_str());
    }
    return limited(paths, arguments);
  };
  if (arguments.has("--images")) {
    database_paths = list("--images");
    run.mode = "sequence";
  } else if (arguments.has("--database") && arguments.has("--queries")) {
    database_paths = list("--database");
    query_paths = list("--queries");
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
                 "lcd_evaluate: %zu images, %zu keyframes (%zu without odometry around them, "
                 "messages at most %.2f s apart; %zu refused)\n",
                 keyframes.images_read, keyframes.images.size(), keyframes.images_without_odometry,
                 bag.odometry_max_interval, keyframes.images_rejected);
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
  if (no_truth) {
    truth = GroundTruth(run.query_images, run.database_images);
    truth.finalize();
    run.ground_truth = "none";
  } else if (arguments.has("--gt-mat")) {
    truth = readMatGroundTruth(arguments.get("--gt-mat"), arguments.get("--gt-var"));
    run.ground_truth = arguments.get("--gt-mat");
    if (!traversal && truth.rows() == truth.cols()) truth = truth.undirected();
  } else if (arguments.has("--gt-aligned")) {
    const int tolerance = static_cast<int>(arguments.number("--gt-aligned", 0));
    if (traversal) {
      truth = alignedGroundTruth(query_paths.size(), database_paths.size(), tolerance);
    } else if (first_traversal > 0) {
      // Image first_traversal + i of the second traversal is image i of the first, +- tolerance.
      const double stop_threshold = arguments.number("--gt-stops", 0.0);
      std::vector<bool>& stops = joint_stops;
      if (stop_threshold > 0.0) {
        stops =
            tools::jointStops(std::vector<std::string>(database_paths.begin(),
                                                       database_paths.begin() + first_traversal),
                              std::vector<std::string>(database_paths.begin() + first_traversal,
                                                       database_paths.end()),
                              stop_threshold);
      }
      const GroundTruth across = alignedGroundTruth(database_paths.size() - first_traversal,
                                                    first_traversal, tolerance, stops);
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
    if (arguments.has("--gt-stops")) {
      run.ground_truth += " moving frames (a stop of both traversals is one place)";
    }
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
  if (!no_truth) requirePositives(truth, run.ground_truth);
  const CameraIntrinsics camera =
      cameraInfoFor(arguments, imageLoader(memory, database_paths, image_width)(0));
  if (camera.valid() && !arguments.has("--detector") && !arguments.has("--appearance-check")) {
    std::fprintf(stderr,
                 "--camera-info is used by --detector and --appearance-check only: not used "
                 "here\n");
  }
  if (arguments.has("--dry-run") && !arguments.has("--detector")) {
    for (const std::string& name : names) descriptorVariant(name, arguments);
    std::printf(
        "dry run: %zu database and %zu query images of %s, ground truth %s, descriptors %s;"
        " nothing evaluated\n",
        run.database_images, run.query_images, run.dataset.c_str(), run.ground_truth.c_str(),
        arguments.get("--descriptors", "the defaults").c_str());
    return 0;
  }
  if (arguments.has("--detector")) {
    std::vector<Pose> poses;
    std::vector<double> stamps;
    if (arguments.has("--gt-poses")) {
      poses = run.trajectory;
      stamps = readNumbers(arguments.get("--gt-times"));
    }
    // Aligned traversals stand where both stand: each frame of one is the other's place.
    std::vector<bool> standing;
    if (arguments.has("--still-joint")) {
      if (joint_stops.empty()) throw std::invalid_argument("--still-joint needs --gt-stops G");
      for (size_t i = 0; i < database_paths.size(); ++i) {
        const size_t place = i < first_traversal ? i : i - first_traversal;
        standing.push_back(place < joint_stops.size() && joint_stops[place]);
      }
    }
    ImageRuns runs;
    runs.protocol = runProtocol(arguments.get("--protocol", "one-sequence"));
    if (runs.protocol != RunProtocol::kOneSequence) {
      if (first_traversal == 0 || !poses.empty()) {
        throw std::invalid_argument(
            "--protocol sessions|localisation|one-run|robots plays --database then --queries "
            "(--as-sequence) "
            "as two runs of an image-only sequence");
      }
      runs.starts = {first_traversal};
    }
    if (runs.protocol == RunProtocol::kOneRun && !arguments.has("--still-joint") &&
        arguments.number("--still-threshold", 5.0) != 0.0) {
      throw std::invalid_argument(
          "--protocol one-run closes the route after the first traversal's steps, which must "
          "be known before it plays: --still-threshold 0 (every image a step) or --still-joint");
    }
    runs.heading_drift = arguments.number("--odometry-drift", runs.heading_drift);
    DetectorSource source = imageSequenceSource(database_paths, truth, poses, stamps, camera,
                                                arguments.number("--still-threshold", 5.0),
                                                image_width, standing, runs);
    // The histogram's bins reach the tolerance the truth allows: beyond it a loop is false.
    source.offset_tolerance = arguments.number("--gt-aligned", 0.0);
    source.offset = [truth, tolerance = source.offset_tolerance](size_t query, size_t match) {
      return framesFromTruth(truth, query, match, tolerance);
    };
    return runDetectorMode(arguments, source, run.dataset, output_folder);
  }

  // Training images of the learned descriptors: --train-images, or with --train-on-eval the
  // database (traversals) or the whole sequence; read in colour (each descriptor turns them grey
  // when it wants).
  Training training;
  if (arguments.has("--train-images")) {
    auto paths =
        std::make_shared<std::vector<std::string>>(listImages(arguments.get("--train-images")));
    training = {
        paths->size(),
        [paths, image_width](size_t i) { return readImage((*paths)[i], true, image_width); },
        arguments.get("--train-images")};
  } else if (arguments.has("--train-on-eval") && !memory.images.empty()) {
    training = {memory.images.size(), [&memory](size_t i) { return memory.images[i]; },
                "the evaluated sequence itself (--train-on-eval)"};
  } else if (arguments.has("--train-on-eval")) {
    training = {database_paths.size(),
                [&database_paths, image_width](size_t i) {
                  return readImage(database_paths[i], true, image_width);
                },
                "the evaluated database images themselves (--train-on-eval)"};
  }

  const MatchChecks match_checks = arguments.has("--appearance-check")
                                       ? matchChecks(arguments.get("--config"), camera)
                                       : MatchChecks();
  std::vector<Evaluation> evaluations;
  for (const std::string& name : names) {
    Variant variant = descriptorVariant(name, arguments);
    const bool trains = needsTraining(variant);
    std::shared_ptr<const DescriptorExtractor> extractor =
        makeVariantExtractor(&variant, name, training, output_folder);
    DescribedImages database;
    if (!memory.images.empty()) {
      database = describeImages(
          memory.images.size(), [&](size_t i) { return memory.images[i]; }, *extractor,
          progressPrinter("describing (" + name + ")"));
    } else {
      database =
          describeImageFiles(database_paths, *extractor,
                             progressPrinter("describing database (" + name + ")"), image_width);
    }
    for (const std::string& path : database.undecodable) {
      std::cerr << "lcd_evaluate: skipped an image that does not decode: " << path << "\n";
    }
    standardiseConditions(&database, condition_window, ConditionStart::kStored);
    const cv::Mat first_image = !memory.images.empty() ? memory.images.front()
                                : database_paths.empty()
                                    ? cv::Mat()
                                    : readImage(database_paths.front(), false, image_width);
    if (!first_image.empty()) {
      std::printf("%-10s %s\n", name.c_str(), extractor->describesAs(first_image.size()).c_str());
    }
    Evaluation evaluation;
    if (traversal) {
      DescribedImages queries =
          describeImageFiles(query_paths, *extractor,
                             progressPrinter("describing queries (" + name + ")"), image_width);
      for (const std::string& path : queries.undecodable) {
        std::cerr << "lcd_evaluate: skipped an image that does not decode: " << path << "\n";
      }
      standardiseConditions(&queries, condition_window);
      evaluation = evaluateTraversals(database, queries, truth, *extractor, matching,
                                      progressPrinter("matching (" + name + ")"));
    } else {
      evaluation = evaluateSequence(database, truth, *extractor, matching,
                                    progressPrinter("matching (" + name + ")"));
    }
    evaluation.name = name;
    if (trains) evaluation.training_source = training.source;
    if (arguments.has("--appearance-check")) {
      checkMatches(&evaluation, *extractor, match_checks,
                   imageLoader(memory, traversal ? query_paths : database_paths, image_width),
                   imageLoader(memory, database_paths, image_width));
    }
    const Metrics& m = evaluation.metrics;
    if (no_truth) {
      std::printf(
          "%-10s no ground truth: best matches in matches_%s.csv  describe %.2f/%.2f ms  "
          "query %.2f/%.2f ms (median/p99)\n",
          name.c_str(), name.c_str(), evaluation.describe_ms.median, evaluation.describe_ms.p99,
          evaluation.query_ms.median, evaluation.query_ms.p99);
    } else {
      std::printf(
          "%-10s R@100P %.3f  AUC %.3f  AP %.3f  R@1 %.3f  VPR-Bench R@100P %.3f AUC %.3f  "
          "describe %.2f/%.2f ms  query %.2f/%.2f ms (median/p99)  %.0f bytes/image\n",
          name.c_str(), m.recall_at_100_precision, m.auc, m.average_precision, m.recall_at_1,
          m.vprbench.recall_at_100_precision, m.vprbench.auc, evaluation.describe_ms.median,
          evaluation.describe_ms.p99, evaluation.query_ms.median, evaluation.query_ms.p99,
          evaluation.bytes_per_image);
      if (m.unmatched_with_truth > 0) {
        std::printf(
            "%-10s %zu of %zu queries with a place matched nothing, counted as misses: their "
            "vectors are all zeros (a traversal's first image standardised alone, or a camera "
            "standing still), as the node would match nothing with them\n",
            name.c_str(), m.unmatched_with_truth, m.queries_with_truth);
      }
    }
    if (no_truth || arguments.has("--contact-sheet")) {
      const std::string sheet = output_folder + "/contact_" + name + ".png";
      writeContactSheet(sheet, evaluation.outcomes,
                        imageLoader(memory, traversal ? query_paths : database_paths, image_width),
                        imageLoader(memory, database_paths, image_width), !no_truth,
                        static_cast<int>(arguments.number("--contact-sheet", 24)));
      std::printf("           contact sheet: %s\n", sheet.c_str());
    }
    evaluations.push_back(std::move(evaluation));
  }
  const std::string results =
      writeReport(output_folder, run, evaluations, truth, matching.matrix_size);
  std::printf("results: %s\n", results.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Arguments arguments;
  if (const auto exit_code = parse(argc, argv, &arguments)) return *exit_code;
  try {
    return run(arguments);
  } catch (const std::invalid_argument& error) {
    std::cerr << "lcd_evaluate: " << error.what() << "\n(lcd_evaluate --help lists every option)\n";
    return 2;
  } catch (const std::exception& error) {
    std::cerr << "lcd_evaluate: error: " << error.what() << "\n";
    return 1;
  }
}
