#pragma once

#include <string>
#include <utility>
#include <vector>

#include "landmark_loop_closure/common/parameter_source.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/fleet/fleet_matcher.h"
#include "landmark_loop_closure/runtime/detector_runtime.h"

namespace landmark_loop_closure {

/// Where the robot's pose comes from.
enum class PoseSource {
  kOdom,  ///< nav_msgs/Odometry synced with the images.
  kTf,    ///< A tf lookup odom_frame <- base_frame at each image's stamp.
};
/// The frame published metric relative poses are expressed in.
enum class RelativePoseFrame {
  kCamera,  ///< The image's optical frame.
  kBase,    ///< The robot's base_frame.
};

/// The parameters' words for each value ("odom", "tf"; "camera", "base"; "drop", "reset").
const std::vector<std::pair<std::string, PoseSource>>& poseSourceNames();
const std::vector<std::pair<std::string, RelativePoseFrame>>& relativePoseFrameNames();
const std::vector<std::pair<std::string, TimeJumpPolicy>>& timeJumpPolicyNames();
/// The word of a value in such a table.
template <typename Enum>
std::string nameOf(const std::vector<std::pair<std::string, Enum>>& names, Enum value) {
  for (const auto& [name, choice] : names) {
    if (choice == value) return name;
  }
  return "?";
}

/// Everything the nodelet reads from its private parameters. The in-class initialisers are the
/// defaults; parameters() declares each key's range and description.
struct NodeOptions {
  PoseSource pose_source = PoseSource::kOdom;
  std::string odom_frame = "odom";  ///< tf mode: fixed frame of the lookup.
  /// The robot's body frame: tf mode looks its pose up; camera_mount_from_tf and
  /// relative_pose_frame "base" use it in both modes.
  std::string base_frame = "base_link";
  double tf_timeout = 0.2;   ///< tf mode: seconds to wait for a transform, then drop.
  int sync_queue_size = 30;  ///< odom mode: images waiting for the odometry after them.
  double sync_slop = 0.05;   ///< Seconds a keyframe and its depth image may differ.
  double odometry_max_interval =
      0.25;                    ///< odom mode: seconds between the messages around an image.
  int worker_queue_size = 8;   ///< Keyframes waiting for the worker thread.
  double input_timeout = 5.0;  ///< Seconds without input before diagnostics warn.
  /// A frame stamped more than time_jump_back_s before the last keyframe (bag restarted, simulated
  /// clock reset): kDrop it (and every frame until time passes the last keyframe again), or
  /// kReset: forget every keyframe, as ~reset does, and start over from it. Smaller steps back
  /// are out-of-order frames and always dropped.
  TimeJumpPolicy time_jump_back = TimeJumpPolicy::kDrop;
  double time_jump_back_s = 1.0;
  /// Frames in a row not after the last keyframe that make a time jump (RuntimeOptions); 0: off.
  int time_jump_frames = 30;
  /// Frames stamped more than this ahead of the node's clock (wall, or /clock with use_sim_time)
  /// are refused; 0 = off.
  double max_stamp_ahead_s = 5.0;
  bool publish_rejected_markers = false;  ///< Also draw rejected candidates in rviz.
  bool images_rectified = false;          ///< `image` is rectified: P's intrinsics, D not applied.
  bool use_depth = false;  ///< Subscribe to `depth` (registered to the image) for metric poses.
  RelativePoseFrame relative_pose_frame = RelativePoseFrame::kCamera;
  /// Look the camera mount up in tf (base_frame <- the image's frame_id) instead of camera_mount/*.
  bool camera_mount_from_tf = false;
  /// No camera_mount value set and from_tf off: the mount is taken from tf where tf has it, the
  /// default values until then (one source by default: the robot's tf).
  bool mountFromTfWhereKnown() const {
    return !camera_mount_from_tf && detector.camera_mount.isDefault() && !base_frame.empty();
  }
  /// The map (KeyframeStore): its keyframes are loaded at start as earlier sessions and every
  /// keyframe is committed to it when stored; "" = memory only.
  std::string database_path;
  LoopDetectorOptions detector;
  FleetOptions fleet;  ///< Loops between robots while they run.
  /// Set when the options had to change to run at all (the pretrained backbone was never
  /// fetched): one line for the node to warn with. Empty otherwise.
  std::string fallback_warning;
  /// Set when the network's description (MODEL.json beside its ONNX file) is missing for a model
  /// of the user's own, or unreadable: validate() reports it.
  std::string description_problem;
  /// Set when keys under descriptor/ were given values the descriptor in use does not read
  /// (advanced/descriptor/model under type backbone): one line naming them. Empty otherwise.
  std::string ignored_warning;

  /// Every key the nodelet reads, each declared once with its range and description.
  static const ParameterTable<NodeOptions>& parameters();
  /// Empty when valid, otherwise every problem, one per line.
  std::string validate() const;
  /// A warning when keypoint depths are triangulated from the odometry with camera_mount left at
  /// its default (the camera at base_frame's origin) and tf lacking the mount: a mount the robot
  /// does not have skews every metric loop, silently. Empty otherwise (said by the node when tf
  /// has no base_frame -> the camera's frame).
  std::string defaultMountWarning() const;
};

/// Reads every option; absent keys keep their defaults. A key moved under `advanced/` is also
/// read from its earlier name (parameterNotes says so).
void readNodeOptions(OptionReader* reader, NodeOptions* options);

/// What lcd_evaluate --config reads: the node's options, and before them the acceptance rules
/// measured and not kept (AcceptanceOptions::evaluationParameters), so that the backbone's
/// fallback sees them too.
void readEvaluationOptions(OptionReader* reader, NodeOptions* options);

/// The name a key had before the two-tier layout: "advanced/keyframe/min_motion" was
/// "advanced/keyframe/min_motion". "" for a key that kept its name.
std::string oldParameterName(const std::string& key);

/// A key the node reads no more, and what to do instead.
struct RemovedParameter {
  const char* key;
  const char* instead;
};
const std::vector<RemovedParameter>& removedParameters();
/// Keys the node keeps at their measured defaults (ParameterTable::evaluationOnly), with those
/// defaults: the evaluation alone reads them.
const std::vector<DocumentedParameter>& fixedParameters();

/// One line for each of `keys` (those a parameter source holds) that `reader`, having read the
/// node's options, found under an old name ("... moved: it is now ..."), that the node no longer
/// reads (what instead), or that is no parameter at all (misspelt?). Empty when all are current.
std::vector<std::string> parameterNotes(const std::vector<std::string>& keys,
                                        const OptionReader& reader);

/// `notes` as the node logs them at start: an unknown key one line each (a misspelt key must not
/// hide among the others), and, past `max_lines`, the keys that moved or are no longer read in
/// one line that counts them, names the first and points at `lcd_config check` for each.
std::vector<std::string> condensedParameterNotes(const std::vector<std::string>& notes,
                                                 size_t max_lines = 3);

/// config/default.yaml as the parameter tables describe it: every key with its default and
/// description. A test keeps the shipped file equal to it; `lcd_config defaults` writes it.
std::string documentedDefaultsYaml();

}  // namespace landmark_loop_closure
