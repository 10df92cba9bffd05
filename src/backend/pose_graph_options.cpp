// The pose graph's parameters and the pose_graph node's, declared once: config/pose_graph.yaml
// is rendered from these tables.
#include <string>
#include <vector>

#include "landmark_loop_closure/backend/pose_graph.h"
#include "landmark_loop_closure/common/text_and_files.h"

namespace landmark_loop_closure {

const ParameterTable<PoseGraphOptions>& PoseGraphOptions::parameters() {
  using O = PoseGraphOptions;
  static const auto table =
      ParameterTable<O>("pose_graph/", "the reference pose-graph backend (Ceres, 6 DoF).")
          .number("odometry_translation_sd_m", &O::odometry_translation_sd_m, above(0),
                  "odometry edge: translation standard deviation per axis, floor (m) ...")
          .number("odometry_translation_sd_per_m", &O::odometry_translation_sd_per_m, atLeast(0),
                  "... plus this share of the distance between the two keyframes;")
          .number("odometry_rotation_sd_rad", &O::odometry_rotation_sd_rad, above(0),
                  "rotation standard deviation per axis, floor (rad) ...")
          .number("odometry_rotation_sd_per_m", &O::odometry_rotation_sd_per_m, atLeast(0),
                  "... plus this many radians per metre travelled ...")
          .number("odometry_rotation_sd_per_rad", &O::odometry_rotation_sd_per_rad, atLeast(0),
                  "... and per radian turned.")
          .number("heading_drift_prior_sd_per_m", &O::heading_drift_prior_sd_per_m, atLeast(0),
                  "the odometry's heading may drift at a steady rate (rad per metre travelled, "
                  "about the body's z axis): the graph estimates that rate from the loops, with "
                  "this prior standard deviation around zero. 0: not estimated.")
          .number("max_loop_error_sd", &O::max_loop_error_sd, above(0),
                  "a loop whose error exceeds this many standard deviations of the uncertainty "
                  "between its keyframes (the odometry along the graph's most certain path plus "
                  "the loop's own covariance) is refused before it enters, or switched off when "
                  "the optimised graph contradicts it.")
          .number("loop_loss_scale", &O::loop_loss_scale, above(0),
                  "Cauchy loss scale of loop residuals, in standard deviations: a wrong loop "
                  "that passed the screening pulls with bounded force.")
          .integer("loop_confirmations", &O::loop_confirmations, between(0, 10),
                   "pairwise consistency: a loop that passed the screening enters the graph only "
                   "once this many other loops nearby agree with it (both ends within "
                   "confirmation_distance_m of its own along the odometry, the cycle the two "
                   "close with the odometry within max_loop_error_sd; a partner the screening "
                   "refused counts too). A wrong loop seldom finds a partner; a true one waits "
                   "for the next loop of its revisit. 0: each loop on its own.")
          .number("confirmation_distance_m", &O::confirmation_distance_m, above(0),
                  "how far apart along the odometry two loops' queries, and their matches, may "
                  "be to confirm each other (m).")
          .integer("max_iterations", &O::max_iterations, between(1, 1000),
                   "solver iterations per optimisation.");
  return table;
}

std::string PoseGraphOptions::validate() const { return parameters().check(*this); }

const ParameterTable<PoseGraphNodeOptions>& PoseGraphNodeOptions::parameters() {
  using O = PoseGraphNodeOptions;
  static const auto table =
      ParameterTable<O>("", "")
          .text("map_frame", &O::map_frame,
                "frame of the corrected path; map_frame -> the keyframes' odometry frame is "
                "published on tf.")
          .text("base_frame", &O::base_frame,
                "the robot's body frame, as the detector's base_frame: loops whose "
                "relative_pose_frame is another frame (not the detector's base_frame) are taken "
                "as the camera's and turned into it with camera_mount (or through tf: "
                "camera_mount/from_tf).")
          .flag("publish_tf", &O::publish_tf, "publish that correction on tf.")
          .number("tf_rate_hz", &O::tf_rate_hz, between(0, 1000),
                  "how often the correction is sent (Hz), stamped tf_future_s ahead of the "
                  "clock, so that a lookup at the newest sensor time finds it while no keyframe "
                  "comes (the robot stands still), as amcl and slam_toolbox send theirs. 0: "
                  "once per keyframe, stamped with it.")
          .number("tf_future_s", &O::tf_future_s, between(0, 1),
                  "how far ahead of the clock each sending is stamped (s).")
          .text("detector", &O::detector,
                "the detector node (its name, resolved in this node's namespace) whose "
                "camera_mount, camera_mount/from_tf and base_frame are used here, so the camera "
                "mount is set once, for both; the values below only when it is empty or that "
                "node has no parameters (said at start). A loop in the detector's base_frame "
                "other than base_frame is left out, named in the log. The graph is saved beside "
                "that node's database_path (as MAP-pose_graph) and restored from it at start.")
          .text("robots", &O::robots,
                "several robots' detectors in one graph (docs/robots.md): their "
                "namespaces, separated by spaces or commas (e.g. \"/robot_a /robot_b\"), whose "
                "keyframes and loop_closures are read; each robot's corrected path is published "
                "on ~ROBOT/corrected_path and map -> each robot's odometry frame on tf. Time "
                "going back then starts a new graph only within one map. Empty: this "
                "namespace's keyframes and loop_closures.")
          .group(&O::camera_mount, CameraMount::parameters())
          .flag("camera_mount/from_tf", &O::camera_mount_from_tf,
                "turn loops whose relative_pose_frame is not base_frame through tf instead of "
                "the values above (base_frame -> that frame, latest: the camera's optical frame "
                "as the detector names it, or any other); a loop whose frame tf does not know "
                "yet is left out, named in the log. Off with none of the values above set: tf "
                "is asked first all the same, the default values serve until it has the frame. "
                "With `detector`, the detector's setting and values.")
          .group(&O::graph, PoseGraphOptions::parameters());
  return table;
}

std::vector<std::string> PoseGraphNodeOptions::robotList() const { return parseNameList(robots); }

std::string PoseGraphNodeOptions::validate() const {
  std::string problems = parameters().check(*this);
  if (map_frame.empty()) problems += "map_frame must not be empty\n";
  if (base_frame.empty()) problems += "base_frame must not be empty\n";
  return problems + camera_mount.validate() + graph.validate();
}

std::string poseGraphDefaultsYaml() {
  std::vector<DocumentedParameter> parameters;
  PoseGraphNodeOptions::parameters().document(PoseGraphNodeOptions{}, &parameters);
  return renderParameterYaml(
      parameters,
      "landmark_loop_closure pose_graph: every parameter of the reference pose-graph backend, "
      "with its default. Written by `lcd_config pose_graph_defaults` from the declarations in "
      "src/backend/pose_graph_options.cpp; a test fails when the two differ.");
}

}  // namespace landmark_loop_closure
