#include "landmark_loop_closure/config/node_options.h"

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

#include "landmark_loop_closure/common/text_and_files.h"
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
          .section("The map on disk")
          .text("database_path", &O::database_path,
                "the map: an SQLite file (created when missing) and its rows file PATH-vectors "
                "beside it (keep the two together), whose keyframes are loaded at "
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
          .section("Inputs")
          .choice("pose_source", &O::pose_source, poseSourceNames(),
                  "\"odom\": images with nav_msgs/Odometry on `odom`, interpolated to each image's "
                  "stamp; \"tf\": images only, pose = tf lookup odom_frame -> base_frame at the "
                  "image stamp.")
          .text("odom_frame", &O::odom_frame,
                "tf mode: fixed frame of the lookup (odom mode uses the odometry's frame_id).")
          .text("base_frame", &O::base_frame,
                "the robot's body frame: tf mode looks its pose up; camera_mount/from_tf and "
                "relative_pose_frame: base use it in both modes. odom mode: odometry whose "
                "child_frame_id is another frame is turned into base_frame's pose through tf "
                "(child_frame_id -> base_frame, latest), or dropped with an error until tf has "
                "it; an empty child_frame_id is taken as base_frame.")
          .number("tf_timeout", &O::tf_timeout, atLeast(0),
                  "tf mode: seconds to wait for the transform at an image stamp, then drop the "
                  "image.")
          .integer("sync_queue_size", &O::sync_queue_size, between(1, 1000),
                   "odom mode: images held until the odometry message after their stamp comes "
                   "(visual odometry publishes after the image); when full the oldest is dropped "
                   "with a warning.")
          .number("odometry_max_interval", &O::odometry_max_interval, above(0),
                  "odom mode: an image's pose is the odometry interpolated to its stamp (position "
                  "linearly, orientation by slerp) between the messages just before and after "
                  "it, which may be at most this far apart (s); an image at a message's stamp "
                  "takes it. Images the odometry cannot place are dropped with the reason.")
          .number("sync_slop", &O::sync_slop, above(0),
                  "largest stamp difference between a keyframe and its depth image (s).")
          .integer("worker_queue_size", &O::worker_queue_size, between(1, 10000),
                   "keyframes waiting for the worker thread; when full the oldest is dropped and "
                   "counted. Each holds its image (~1 MB at 640x480 colour).")
          .number("input_timeout", &O::input_timeout, above(0),
                  "diagnostics warn when no image/odometry arrived for this long (s), and a "
                  "warning names the stamps when both arrive but never pair.")
          .choice("time_jump_back", &O::time_jump_back, timeJumpPolicyNames(),
                  "a frame more than time_jump_back_s older than the last keyframe (bag "
                  "restarted, sim clock reset): \"drop\" it and every frame until time passes "
                  "the last keyframe again; \"reset\": forget every keyframe (as ~reset) and "
                  "start over from it. Smaller steps back are always dropped.")
          .number("time_jump_back_s", &O::time_jump_back_s, above(0),
                  "seconds back that count as a jump rather than an out-of-order frame; odometry "
                  "that jumps back this far starts its history afresh (images waiting for the "
                  "earlier timeline's odometry are dropped).")
          .integer("time_jump_frames", &O::time_jump_frames, between(0, 100000),
                   "this many frames in a row not after the last keyframe are a time jump "
                   "whatever its size (a keyframe with a wrong stamp, the clock set back): "
                   "logged, diagnostics ERROR for 30 s, and the next frame starts a new "
                   "timeline - keeping the map under \"drop\", forgetting it under \"reset\" - "
                   "instead of every frame being dropped until time passes that stamp. 0 = off.")
          .number("max_stamp_ahead_s", &O::max_stamp_ahead_s, atLeast(0),
                  "frames stamped more than this ahead of the node's clock (wall time, or /clock "
                  "with use_sim_time) are dropped before they can become a keyframe: one such "
                  "frame would make every later one \"not after the last keyframe\" until the "
                  "clock caught up. 0 = off.")
          .flag("publish_rejected_markers", &O::publish_rejected_markers,
                "also draw rejected loop candidates in ~markers (grey lines).")
          .flag("images_rectified", &O::images_rectified,
                "true: `image` is rectified (image_proc's image_rect): camera_info's P gives the "
                "intrinsics and its D is not applied. false (image_raw): K, and keypoints are "
                "corrected for the lens by D (plumb_bob, rational_polynomial, equidistant).")
          .flag("use_depth", &O::use_depth,
                "subscribe to `depth` (16UC1 mm or 32FC1 m, registered to `image`, any size): "
                "keyframes take their keypoint depths from the depth image nearest in time "
                "(within sync_slop) instead of triangulating them.")
          .choice("relative_pose_frame", &O::relative_pose_frame, relativePoseFrameNames(),
                  "frame of published metric relative poses: \"camera\" (the image's optical "
                  "frame_id) or \"base\" (base_frame, via the camera mount). Scale-free poses "
                  "always stay in the camera frame. The message names the frame.")
          .section("Detector")
          .group(&O::detector, LoopDetectorOptions::parameters())
          .flag("camera_mount/from_tf", &O::camera_mount_from_tf,
                "look the mount up in tf (base_frame -> the image's frame_id, latest) instead of "
                "the values above; until tf has it, depths are not triangulated. Off with none "
                "of the values above set: tf is asked first all the same, and the default "
                "values serve until it has the mount (warned once).")
          .section("Other robots")
          .group(&O::fleet, FleetOptions::parameters());
  return table;
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
         "(camera_mount/from_tf: true waits for tf instead), else metric loops carry the mount's "
         "error";
}

std::string NodeOptions::validate() const {
  std::ostringstream errors;
  errors << parameters().check(*this);
  const bool needs_base = pose_source == PoseSource::kTf ||
                          relative_pose_frame == RelativePoseFrame::kBase || camera_mount_from_tf;
  if (needs_base && base_frame.empty()) {
    errors << "base_frame must not be empty with pose_source tf, relative_pose_frame base or "
              "camera_mount/from_tf\n";
  }
  if (pose_source == PoseSource::kTf) {
    if (odom_frame.empty()) errors << "odom_frame must not be empty when pose_source is tf\n";
    if (odom_frame == base_frame && !odom_frame.empty()) {
      errors << "odom_frame and base_frame are both '" << odom_frame << "'\n";
    }
  }
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

void readNodeOptions(OptionReader* reader, NodeOptions* options) {
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
      warning += " (acceptance/min_score " + std::to_string(kLandmarksMinScore).substr(0, 4) +
                 ", its tuned value";
      if (normalised) warning += ", and no score_normalisation, which it cannot use";
      warning += ")";
    }
    // Its threshold was tuned on single-image scores, and re-ranking every step of every path
    // would cost a landmark match each.
    if (acceptance.sequence.length == SequenceMatchingOptions().length) {
      acceptance.sequence.length = 1;
      warning += " (acceptance/sequence_length 1: its threshold is for single images)";
    }
    acceptance.score_normalisation = ScoreNormalisation::kNone;
    options->fallback_warning = warning;
  }
  const std::vector<std::string> ignored = ignoredDescriptorParameters(detector.descriptor);
  options->ignored_warning.clear();
  if (!ignored.empty()) {
    std::string keys;
    for (const std::string& key : ignored) keys += (keys.empty() ? "" : ", ") + key;
    const DescriptorType* type = findDescriptorType(detector.descriptor.type);
    options->ignored_warning = "descriptor/type " + detector.descriptor.type + " does not read " +
                               keys + ": " + (ignored.size() == 1 ? "it is" : "they are") +
                               " set but change nothing (" + type->name + ": " + type->summary +
                               ")";
  }
}

}  // namespace landmark_loop_closure
