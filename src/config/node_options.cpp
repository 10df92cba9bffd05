#include "landmark_loop_closure/config/node_options.h"

#include <algorithm>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "landmark_loop_closure/common/text_and_files.h"
#include "landmark_loop_closure/descriptors/model_description.h"
#include "landmark_loop_closure/descriptors/registry.h"

namespace landmark_loop_closure {

const std::vector<std::pair<std::string, PoseSource>>& poseSourceNames() {
  static const std::vector<std::pair<std::string, PoseSource>> names = {{"odom", PoseSource::kOdom},
                                                                        {"tf", PoseSource::kTf}};
  return names;
}

const std::vector<std::pair<std::string, RelativePoseFrame>>& relativePoseFrameNames() {
  static const std::vector<std::pair<std::string, RelativePoseFrame>> names = {
      {"camera", RelativePoseFrame::kCamera}, {"base", RelativePoseFrame::kBase}};
  return names;
}

const std::vector<std::pair<std::string, TimeJumpPolicy>>& timeJumpPolicyNames() {
  static const std::vector<std::pair<std::string, TimeJumpPolicy>> names = {
      {"drop", TimeJumpPolicy::kDrop}, {"reset", TimeJumpPolicy::kReset}};
  return names;
}

const ParameterTable<NodeOptions>& NodeOptions::parameters() {
  using O = NodeOptions;
  static const auto table =
      ParameterTable<O>("", "")
          .section("Your robot: the questions a robot's setup answers (docs/robot_setup.md)")
          .text("database_path", &O::database_path,
                "where is the map kept? An SQLite file (created when missing) and its rows file "
                "PATH-vectors beside it (keep the two together), whose keyframes are loaded at "
                "start as earlier sessions; every keyframe is committed to it when it is stored, "
                "so a crash loses at most the keyframes still queued. \"\" = memory only. A "
                "leading ~ and $VARIABLES are expanded, here and in the model paths. "
                "Services ~save_database (a copy to `path`), ~load_database (switch to the map "
                "at `path`) and ~reset (the old file is kept as PATH.reset-TIME). A file that "
                "cannot be opened (damaged, empty or not a map, other descriptors, open in "
                "another node, the earlier format: `lcd_db convert`) stops the node with the "
                "reason and is left alone; search starts at once and the map's pages and the rows "
                "saved at the last clean shutdown are checked beside it (new keyframes are held "
                "in memory until the check passes): found damaged, search stops with one error "
                "and the map is never written to again (keyframes are kept in memory only).")
          .group(&O::detector, LoopDetectorOptions::modeParameter())
          .choice("pose_source", &O::pose_source, poseSourceNames(),
                  "where does the robot's pose come from? \"odom\": images with "
                  "nav_msgs/Odometry on `odom`, interpolated to each image's stamp; \"tf\": "
                  "images only, pose = tf lookup advanced/odom_frame -> base_frame at the image "
                  "stamp.")
          .text("base_frame", &O::base_frame,
                "which frame is the robot's body? tf mode looks its pose up; the camera mount "
                "is looked up in tf from it, and advanced/relative_pose_frame: base uses it. odom "
                "mode: odometry whose child_frame_id is another frame is turned into "
                "base_frame's pose through tf (child_frame_id -> base_frame, latest), or dropped "
                "with an error until tf has it; an empty child_frame_id is taken as base_frame.")
          .flag("images_rectified", &O::images_rectified,
                "is `image` rectified? true: image_proc's image_rect: camera_info's P gives the "
                "intrinsics and its D is not applied. false (image_raw): K, and keypoints are "
                "corrected for the lens by D (plumb_bob, rational_polynomial, equidistant).")
          .flag("use_depth", &O::use_depth,
                "is there a depth image registered to `image`? true: subscribe to `depth` "
                "(16UC1 mm or 32FC1 m, any size): keyframes take their keypoint depths from the "
                "depth image nearest in time (within advanced/sync_slop) instead of "
                "triangulating them.")
          .group(&O::detector, LoopDetectorOptions::mountParameters())
          .mapDoc("advanced",
                  "every other parameter: defaults measured on real data (bench/README.md), "
                  "grouped by stage; change one for a reason you have measured.")
          .section("Inputs")
          .text("advanced/odom_frame", &O::odom_frame,
                "tf mode: fixed frame of the lookup (odom mode uses the odometry's frame_id).")
          .number("advanced/tf_timeout", &O::tf_timeout, atLeast(0),
                  "tf mode: seconds to wait for the transform at an image stamp, then drop the "
                  "image.")
          .integer("advanced/sync_queue_size", &O::sync_queue_size, between(1, 1000),
                   "odom mode: images held until the odometry message after their stamp comes "
                   "(visual odometry publishes after the image); when full the oldest is dropped "
                   "with a warning.")
          .number("advanced/odometry_max_interval", &O::odometry_max_interval, above(0),
                  "odom mode: an image's pose is the odometry interpolated to its stamp (position "
                  "linearly, orientation by slerp) between the messages just before and after "
                  "it, which may be at most this far apart (s); an image at a message's stamp "
                  "takes it. Images the odometry cannot place are dropped with the reason.")
          .number("advanced/sync_slop", &O::sync_slop, above(0),
                  "largest stamp difference between a keyframe and its depth image (s).")
          .integer("advanced/worker_queue_size", &O::worker_queue_size, between(1, 10000),
                   "keyframes waiting for the worker thread; when full the oldest is dropped and "
                   "counted. Each holds its image (~1 MB at 640x480 colour).")
          .number("advanced/input_timeout", &O::input_timeout, above(0),
                  "diagnostics warn when no image/odometry arrived for this long (s), and a "
                  "warning names the stamps when both arrive but never pair.")
          .choice("advanced/time_jump_back", &O::time_jump_back, timeJumpPolicyNames(),
                  "a frame more than time_jump_back_s older than the last keyframe (bag "
                  "restarted, sim clock reset): \"drop\" it and every frame until time passes "
                  "the last keyframe again; \"reset\": forget every keyframe (as ~reset) and "
                  "start over from it. Smaller steps back are always dropped.")
          .number("advanced/time_jump_back_s", &O::time_jump_back_s, above(0),
                  "seconds back that count as a jump rather than an out-of-order frame; odometry "
                  "that jumps back this far starts its history afresh (images waiting for the "
                  "earlier timeline's odometry are dropped).")
          .integer("advanced/time_jump_frames", &O::time_jump_frames, between(0, 100000),
                   "this many frames in a row not after the last keyframe are a time jump "
                   "whatever its size (a keyframe with a wrong stamp, the clock set back): "
                   "logged, diagnostics ERROR for 30 s, and the next frame starts a new "
                   "timeline - keeping the map under \"drop\", forgetting it under \"reset\" - "
                   "instead of every frame being dropped until time passes that stamp. 0 = off.")
          .number("advanced/max_stamp_ahead_s", &O::max_stamp_ahead_s, atLeast(0),
                  "frames stamped more than this ahead of the node's clock (wall time, or /clock "
                  "with use_sim_time) are dropped before they can become a keyframe: one such "
                  "frame would make every later one \"not after the last keyframe\" until the "
                  "clock caught up. 0 = off.")
          .flag("advanced/camera_mount/from_tf", &O::camera_mount_from_tf,
                "look the mount up in tf (base_frame -> the image's frame_id, latest) instead of "
                "camera_mount's values; until tf has it, depths are not triangulated. Off with "
                "none of camera_mount's values set: tf is asked first all the same, and the "
                "default values serve until it has the mount (warned once).")
          .section("Outputs")
          .flag("advanced/publish_rejected_markers", &O::publish_rejected_markers,
                "also draw rejected loop candidates in ~markers (grey lines).")
          .choice("advanced/relative_pose_frame", &O::relative_pose_frame, relativePoseFrameNames(),
                  "frame of published metric relative poses: \"camera\" (the image's optical "
                  "frame_id) or \"base\" (base_frame, via the camera mount). Scale-free poses "
                  "always stay in the camera frame. The message names the frame.")
          .section("Detector")
          .group(&O::detector, LoopDetectorOptions::parameters())
          .section("Other robots")
          .group(&O::fleet, FleetOptions::parameters());
  return table;
}

std::string oldParameterName(const std::string& key) {
  static const std::string kAdvanced = "advanced/";
  return key.compare(0, kAdvanced.size(), kAdvanced) == 0 ? key.substr(kAdvanced.size()) : "";
}

std::string NodeOptions::defaultMountWarning() const {
  if (!detector.camera_mount.isDefault() || camera_mount_from_tf || use_depth ||
      !detector.metric_pose.triangulate_from_odometry) {
    return "";
  }
  const std::string base = base_frame.empty() ? std::string("the base frame") : base_frame;
  return "camera_mount is the default (the camera at '" + base +
         "''s origin, looking along its x axis), tf has no " + base +
         " -> the camera's frame, and keypoint depths are triangulated from the odometry: "
         "publish that transform on tf (a URDF or static_transform_publisher) or set "
         "camera_mount/x, y, z, roll, pitch, yaw to where the camera sits on the robot "
         "(advanced/camera_mount/from_tf: true waits for tf instead), else metric loops carry the "
         "mount's "
         "error";
}

std::string NodeOptions::validate() const {
  std::ostringstream errors;
  errors << parameters().check(*this);
  const bool needs_base = pose_source == PoseSource::kTf ||
                          relative_pose_frame == RelativePoseFrame::kBase || camera_mount_from_tf;
  if (needs_base && base_frame.empty()) {
    errors << "base_frame must not be empty with pose_source tf, relative_pose_frame base or "
              "advanced/camera_mount/from_tf\n";
  }
  if (pose_source == PoseSource::kTf) {
    if (odom_frame.empty()) errors << "odom_frame must not be empty when pose_source is tf\n";
    if (odom_frame == base_frame && !odom_frame.empty()) {
      errors << "odom_frame and base_frame are both '" << odom_frame << "'\n";
    }
  }
  if (!description_problem.empty()) errors << description_problem << "\n";
  errors << detector.validate() << fleet.validate();
  return errors.str();
}

std::string documentedDefaultsYaml() {
  std::vector<DocumentedParameter> parameters;
  NodeOptions::parameters().document(NodeOptions{}, &parameters);
  return renderParameterYaml(
      parameters,
      "landmark_loop_closure: every parameter of the nodelet, with its default. Load it into the "
      "nodelet's private namespace (launch/loop_closure.launch does); override single keys in "
      "your own file passed as the launch argument `config`. Written by `lcd_config defaults` "
      "from the parameter declarations in src/ (each options struct's parameters()): change "
      "those, then regenerate; a test fails when the two differ.");
}

const std::vector<RemovedParameter>& removedParameters() {
  static constexpr char kDescribed[] =
      "a network's preprocessing is a property of its model file: its description MODEL.json "
      "beside the ONNX file (model/mobilenet_v2.onnx.json is an example)";
  // Measured and not kept (bench/history.md has each comparison); lcd_evaluate reproduces them.
  static const std::vector<RemovedParameter> removed = {
      {"acceptance/score_normalisation",
       "no normalisation beat the raw score with the calibrated decision; lcd_evaluate --config "
       "still reads it"},
      {"acceptance/contrast_window", "it served score_normalisation local_contrast (removed)"},
      {"acceptance/consistency_unit",
       "consistency in keyframes was kept, in metres not; lcd_evaluate --config still reads it"},
      {"acceptance/consistent_distance_m", "it served consistency_unit metres (removed)"},
      {"acceptance/match_window_m", "it served consistency_unit metres (removed)"},
      {"descriptor/landmark_features",
       "hog won; lcd_evaluate's landmarks_conv and landmarks_per_landmark reproduce the others"},
      {"descriptor/landmark_grid",
       "it served landmark_features conv (lcd_evaluate landmarks_gridN); lcd_evaluate --config "
       "still reads it"},
      {"descriptor/landmark_layer",
       "it served landmark_features conv (lcd_evaluate landmarks_conv3); lcd_evaluate --config "
       "still reads it"},
      {"descriptor/landmark_storage",
       "float16 lost nothing measurable and is kept (lcd_evaluate landmarks_f32); lcd_evaluate "
       "--config still reads it"},
      {"descriptor/shape_weighting",
       "the penalising weighting won (lcd_evaluate landmarks_paper reproduces the paper's); "
       "lcd_evaluate --config still reads it"},
      {"descriptor/backbone/normalisation",
       "cells won (lcd_evaluate backbone_whole, backbone_centred); lcd_evaluate --config still "
       "reads it"},
      {"descriptor/backbone/cell_pooling_power",
       "the mean won (lcd_evaluate backbone_gemN); lcd_evaluate --config still reads it"},
      {"descriptor/backbone/vocabulary",
       "the grid beat VLAD (lcd_evaluate backbone_vladK, or --vocabulary FILE); lcd_evaluate "
       "--config still reads it"},
      {"descriptor/backbone/vlad_assignments",
       "it served VLAD (lcd_evaluate backbone_softN); lcd_evaluate --config still reads it"},
      {"descriptor/backbone/vlad_features",
       "it served VLAD (lcd_evaluate backbone_vraw); lcd_evaluate --config still reads it"},
      {"descriptor/backbone/vlad_weight",
       "it served VLAD (lcd_evaluate backbone_vwP); lcd_evaluate --config still reads it"},
      {"descriptor/backbone/rerank_weight",
       "landmark re-ranking lost on Gardens Point and the corridor (lcd_evaluate backbone_rP); "
       "lcd_evaluate --config still reads it"},
      {"descriptor/backbone/landmark_grid",
       "it served re-ranking (lcd_evaluate backbone_lgN); lcd_evaluate --config still reads it"},
      {"descriptor/backbone/landmark_features",
       "it served re-ranking (lcd_evaluate backbone_hoglm); lcd_evaluate --config still reads it"},
      {"descriptor/cnn/similarity",
       "both similarities rank alike (lcd_evaluate cnn_pca_cosine); lcd_evaluate --config still "
       "reads it"},
      {"descriptor/backbone/layer", kDescribed},
      {"descriptor/backbone/proposal_layer", kDescribed},
      {"descriptor/backbone/input_width", kDescribed},
      {"descriptor/backbone/input_height", kDescribed},
      {"descriptor/backbone/colour", kDescribed},
      {"descriptor/backbone/mean", kDescribed},
      {"descriptor/backbone/std", kDescribed},
      {"descriptor/cnn/layer", kDescribed},
      {"descriptor/cnn/input_width", kDescribed},
      {"descriptor/cnn/input_height", kDescribed},
      {"descriptor/cnn/colour", kDescribed},
      {"descriptor/cnn/mean", kDescribed},
      {"descriptor/cnn/std", kDescribed},
      // The node no longer trains a descriptor while it runs: training is a tool, then a load.
      {"descriptor/broad/online_training_keyframes",
       "train the model first (`rosrun landmark_loop_closure lcd_train broad --bag YOUR_RUN.bag "
       "--output FILE`) and name it in advanced/descriptor/broad/model"},
  };
  return removed;
}

namespace {
// How parameterNotes words a moved key and an unknown one; condensedParameterNotes tells them
// apart by it.
constexpr char kMoved[] = " moved: it is now ";
constexpr char kNotAParameter[] = " is not a parameter of the node";
}  // namespace

const std::vector<DocumentedParameter>& fixedParameters() {
  static const std::vector<DocumentedParameter> fixed = [] {
    std::vector<DocumentedParameter> all;
    NodeOptions::parameters().document(NodeOptions{}, &all);
    std::vector<DocumentedParameter> evaluation_only;
    std::copy_if(all.begin(), all.end(), std::back_inserter(evaluation_only),
                 [](const DocumentedParameter& p) { return p.evaluation_only; });
    return evaluation_only;
  }();
  return fixed;
}

std::vector<std::string> parameterNotes(const std::vector<std::string>& keys,
                                        const OptionReader& reader) {
  std::vector<std::string> notes;
  for (const std::string& key : keys) {
    const auto record =
        std::find_if(reader.records().begin(), reader.records().end(),
                     [&key](const ParameterRecord& r) { return r.found_under_old_name == key; });
    if (record != reader.records().end()) {
      notes.push_back(key + kMoved + record->key +
                      " (read from the old name this time; rename it)");
      continue;
    }
    if (reader.isKnown(key)) continue;
    const auto fixed = std::find_if(
        fixedParameters().begin(), fixedParameters().end(), [&key](const DocumentedParameter& p) {
          return p.key == key || p.key == "advanced/" + key;  // Today's name or the earlier one.
        });
    if (fixed != fixedParameters().end()) {
      notes.push_back(key +
                      " is no longer a parameter of the node and is ignored: it is fixed at "
                      "its measured value " +
                      fixed->value + " (lcd_evaluate --config still varies it, as " + fixed->key +
                      ")");
      continue;
    }
    const auto removed = std::find_if(
        removedParameters().begin(), removedParameters().end(), [&key](const RemovedParameter& r) {
          return key == r.key || key == std::string("advanced/") + r.key;
        });
    if (removed != removedParameters().end()) {
      notes.push_back(key +
                      " is no longer a parameter of the node and is ignored: " + removed->instead);
    } else {
      notes.push_back(key + kNotAParameter +
                      " and is ignored (misspelt? config/default.yaml lists every key)");
    }
  }
  return notes;
}

std::vector<std::string> condensedParameterNotes(const std::vector<std::string>& notes,
                                                 size_t max_lines) {
  std::vector<std::string> unknown, layout;
  for (const std::string& note : notes) {
    (note.find(kNotAParameter) != std::string::npos ? unknown : layout).push_back(note);
  }
  if (layout.size() > max_lines) {
    const size_t moved = static_cast<size_t>(std::count_if(
        layout.begin(), layout.end(),
        [](const std::string& note) { return note.find(kMoved) != std::string::npos; }));
    unknown.push_back(std::to_string(layout.size()) + " keys are of the layout before advanced/: " +
                      std::to_string(moved) + " moved (read from their old names), " +
                      std::to_string(layout.size() - moved) +
                      " no longer read; the first: " + layout.front() +
                      ". `rosrun landmark_loop_closure lcd_config check YOUR_FILE` names each");
  } else {
    unknown.insert(unknown.end(), layout.begin(), layout.end());
  }
  return unknown;
}

void readEvaluationOptions(OptionReader* reader, NodeOptions* options) {
  reader->setReadsEvaluationOnly(true);
  AcceptanceOptions::evaluationParameters().read(reader, &options->detector.acceptance);
  DescriptorOptions::evaluationParameters().read(reader, &options->detector.descriptor);
  readNodeOptions(reader, options);
}

void readNodeOptions(OptionReader* reader, NodeOptions* options) {
  reader->setOldNames(oldParameterName);
  NodeOptions::parameters().read(reader, options);
  LoopDetectorOptions& detector = options->detector;
  // Paths as users write them in launch and YAML files ("~/maps/lab.db", "$HOME/models/...").
  DescriptorOptions& descriptor = detector.descriptor;
  for (std::string* path :
       {&options->database_path, &descriptor.model, &descriptor.cnn.model,
        &descriptor.cnn.whitening, &descriptor.backbone.model, &descriptor.broad.model}) {
    *path = expandPath(*path);
  }

  // Without the fetched backbone the package's own encoder runs, with its own score scale.
  std::string warning;
  const DescriptorOptions used = withBackboneFallback(detector.descriptor, &warning);
  options->fallback_warning.clear();
  if (!warning.empty()) {
    detector.descriptor = used;
    AcceptanceOptions& acceptance = detector.acceptance;
    // The encoder re-ranks, which no score normalisation works with (a standardised min_score
    // means nothing for it either); its own threshold is a plain similarity.
    const bool normalised = acceptance.score_normalisation != ScoreNormalisation::kNone;
    if (normalised || acceptance.min_score == AcceptanceOptions().min_score) {
      acceptance.min_score = kLandmarksMinScore;
      warning += " (advanced/acceptance/min_score " +
                 std::to_string(kLandmarksMinScore).substr(0, 4) + ", its tuned value";
      if (normalised) warning += ", and no score_normalisation, which it cannot use";
      warning += ")";
    }
    // Its threshold was tuned on single-image scores, and re-ranking every step of every path
    // would cost a landmark match each.
    if (acceptance.sequence.length == SequenceMatchingOptions().length) {
      acceptance.sequence.length = 1;
      warning += " (advanced/acceptance/sequence_length 1: its threshold is for single images)";
    }
    acceptance.score_normalisation = ScoreNormalisation::kNone;
    options->fallback_warning = warning;
  }
  // A network's preprocessing is its description's (MODEL.json beside the ONNX file).
  options->description_problem = applyModelDescriptions(&detector.descriptor);
  const std::vector<std::string> ignored = ignoredDescriptorParameters(detector.descriptor);
  options->ignored_warning.clear();
  if (!ignored.empty()) {
    std::string keys;
    for (const std::string& key : ignored) keys += (keys.empty() ? "" : ", ") + key;
    const DescriptorType* type = findDescriptorType(detector.descriptor.type);
    options->ignored_warning =
        "advanced/descriptor/type " + detector.descriptor.type + " does not read " + keys + ": " +
        (ignored.size() == 1 ? "it is" : "they are") + " set but change nothing (" + type->name +
        ": " + type->summary + ")";
  }
}

}  // namespace landmark_loop_closure
