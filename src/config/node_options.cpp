#include "landmark_loop_closure/config/node_options.h"

#include <algorithm>
#include <sstream>

namespace landmark_loop_closure {

bool OptionReader::isKnown(const std::string& key) const {
  return std::any_of(records_.begin(), records_.end(),
                     [&key](const ParameterRecord& record) { return record.key == key; });
}

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

std::string NodeOptions::validate() const {
  std::ostringstream errors;
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
  if (!(tf_timeout >= 0.0)) errors << "tf_timeout must be >= 0 (got " << tf_timeout << ")\n";
  if (sync_queue_size < 1)
    errors << "sync_queue_size must be >= 1 (got " << sync_queue_size << ")\n";
  if (!(sync_slop > 0.0)) errors << "sync_slop must be > 0 (got " << sync_slop << ")\n";
  if (worker_queue_size < 1) {
    errors << "worker_queue_size must be >= 1 (got " << worker_queue_size << ")\n";
  }
  if (!(input_timeout > 0.0)) errors << "input_timeout must be > 0 (got " << input_timeout << ")\n";
  if (!(time_jump_back_s > 0.0)) {
    errors << "time_jump_back_s must be > 0 (got " << time_jump_back_s << ")\n";
  }
  if (autosave_every < 0) {
    errors << "autosave_every must be >= 0 (got " << autosave_every << ")\n";
  }
  errors << detector.validate();
  return errors.str();
}

void readNodeOptions(OptionReader* reader, NodeOptions* options) {
  reader->readChoice("pose_source", &options->pose_source, poseSourceNames());
  reader->read("odom_frame", &options->odom_frame);
  reader->read("base_frame", &options->base_frame);
  reader->read("tf_timeout", &options->tf_timeout);
  reader->read("sync_queue_size", &options->sync_queue_size);
  reader->read("sync_slop", &options->sync_slop);
  reader->read("worker_queue_size", &options->worker_queue_size);
  reader->read("input_timeout", &options->input_timeout);
  reader->readChoice("time_jump_back", &options->time_jump_back, timeJumpPolicyNames());
  reader->read("time_jump_back_s", &options->time_jump_back_s);
  reader->read("publish_rejected_markers", &options->publish_rejected_markers);
  reader->read("use_depth", &options->use_depth);
  reader->readChoice("relative_pose_frame", &options->relative_pose_frame,
                     relativePoseFrameNames());
  reader->read("camera_mount/from_tf", &options->camera_mount_from_tf);
  reader->read("database_path", &options->database_path);
  reader->read("autoload", &options->autoload);
  reader->read("autosave_every", &options->autosave_every);
  reader->read("save_on_shutdown", &options->save_on_shutdown);

  LoopDetectorOptions& detector = options->detector;
  reader->readChoice("mode", &detector.mode, detectorModeNames());
  reader->read("input/min_image_side", &detector.input.min_image_side);
  reader->read("input/max_image_pixels", &detector.input.max_image_pixels);
  reader->read("input/quaternion_norm_tolerance", &detector.input.quaternion_norm_tolerance);
  reader->read("input/min_image_contrast", &detector.input.min_image_contrast);

  reader->read("keyframe/translation_weight", &detector.keyframe.translation_weight);
  reader->read("keyframe/rotation_weight", &detector.keyframe.rotation_weight);
  reader->read("keyframe/min_motion", &detector.keyframe.min_motion);
  reader->read("keyframe/max_motion", &detector.keyframe.max_motion);
  reader->read("keyframe/max_time_gap", &detector.keyframe.max_time_gap);
  reader->read("keyframe/jump_reanchor_frames", &detector.keyframe.jump_reanchor_frames);

  reader->read("descriptor/type", &detector.descriptor.type);
  reader->read("descriptor/keep_thumbnails", &detector.keep_thumbnails);
  reader->read("descriptor/model", &detector.descriptor.model);
  reader->read("descriptor/max_landmarks", &detector.descriptor.max_landmarks);
  reader->read("descriptor/landmark_grid", &detector.descriptor.landmark_grid);
  reader->read("descriptor/landmark_layer", &detector.descriptor.landmark_layer);
  reader->read("descriptor/shape_weighting", &detector.descriptor.shape_weighting);
  reader->read("descriptor/landmark_features", &detector.descriptor.landmark_features);
  reader->read("descriptor/working_width", &detector.descriptor.working_width);
  reader->read("descriptor/working_height", &detector.descriptor.working_height);
  reader->read("descriptor/landmark_patch", &detector.descriptor.landmark_patch);
  reader->read("descriptor/max_landmark_area", &detector.descriptor.max_landmark_area);
  reader->read("descriptor/landmark_storage", &detector.descriptor.landmark_storage);
  DescriptorOptions::Cnn& cnn = detector.descriptor.cnn;
  reader->read("descriptor/cnn/model", &cnn.model);
  reader->read("descriptor/cnn/layer", &cnn.layer);
  reader->read("descriptor/cnn/input_width", &cnn.input_width);
  reader->read("descriptor/cnn/input_height", &cnn.input_height);
  reader->read("descriptor/cnn/colour", &cnn.colour);
  reader->read("descriptor/cnn/mean", &cnn.mean);
  reader->read("descriptor/cnn/std", &cnn.std);
  reader->read("descriptor/cnn/pooling", &cnn.pooling);
  reader->read("descriptor/cnn/whitening", &cnn.whitening);
  reader->read("descriptor/cnn/similarity", &cnn.similarity);
  DescriptorOptions::Backbone& backbone = detector.descriptor.backbone;
  reader->read("descriptor/backbone/model", &backbone.model);
  reader->read("descriptor/backbone/layer", &backbone.layer);
  reader->read("descriptor/backbone/proposal_layer", &backbone.proposal_layer);
  reader->read("descriptor/backbone/input_width", &backbone.input_width);
  reader->read("descriptor/backbone/input_height", &backbone.input_height);
  reader->read("descriptor/backbone/colour", &backbone.colour);
  reader->read("descriptor/backbone/mean", &backbone.mean);
  reader->read("descriptor/backbone/std", &backbone.std);
  reader->read("descriptor/backbone/grid_rows", &backbone.grid_rows);
  reader->read("descriptor/backbone/grid_cols", &backbone.grid_cols);
  reader->read("descriptor/backbone/normalisation", &backbone.normalisation);
  reader->read("descriptor/backbone/max_landmarks", &backbone.max_landmarks);
  reader->read("descriptor/backbone/landmark_grid", &backbone.landmark_grid);
  reader->read("descriptor/backbone/landmark_features", &backbone.landmark_features);
  reader->read("descriptor/backbone/rerank_weight", &backbone.rerank_weight);
  reader->read("descriptor/backbone/hog_weight", &backbone.hog_weight);
  reader->read("descriptor/backbone/min_network_width", &backbone.min_network_width);
  reader->read("descriptor/backbone/hog_width", &backbone.hog_width);
  reader->read("descriptor/backbone/hog_height", &backbone.hog_height);
  reader->read("descriptor/broad/model", &detector.descriptor.broad.model);
  reader->read("descriptor/broad/online_training_keyframes",
               &detector.descriptor.broad.online_training_keyframes);

  reader->read("database/exclude_recent_keyframes", &detector.database.exclude_recent_keyframes);
  reader->read("database/exclude_recent_seconds", &detector.database.exclude_recent_seconds);
  reader->read("database/min_size", &detector.database.min_size);
  reader->read("database/top_k", &detector.database.top_k);
  reader->read("database/memory_budget_mb", &detector.database.memory_budget_mb);
  IndexOptions& index = detector.database.index;
  reader->read("database/index/type", &index.type);
  reader->read("database/index/approximate_from", &index.approximate_from);
  reader->read("database/index/neighbors", &index.neighbors);
  reader->read("database/index/ef_construction", &index.ef_construction);
  reader->read("database/index/ef_search", &index.ef_search);

  reader->read("acceptance/min_score", &detector.acceptance.min_score);
  reader->read("acceptance/consistent_keyframes", &detector.acceptance.consistent_keyframes);
  reader->read("acceptance/index_window", &detector.acceptance.index_window);
  reader->readChoice("acceptance/consistency_unit", &detector.acceptance.consistency_unit,
                     consistencyUnitNames());
  reader->read("acceptance/consistent_distance_m", &detector.acceptance.consistent_distance_m);
  reader->read("acceptance/match_window_m", &detector.acceptance.match_window_m);
  reader->read("acceptance/sequence_length", &detector.acceptance.sequence.length);
  reader->read("acceptance/sequence_min_speed", &detector.acceptance.sequence.min_speed);
  reader->read("acceptance/sequence_max_speed", &detector.acceptance.sequence.max_speed);
  reader->read("acceptance/sequence_speed_step", &detector.acceptance.sequence.speed_step);
  reader->read("odometry_gate/enabled", &detector.odometry_gate.enabled);
  reader->read("odometry_gate/drift_per_metre", &detector.odometry_gate.drift_per_metre);
  reader->read("odometry_gate/drift_per_radian", &detector.odometry_gate.drift_per_radian);
  reader->read("odometry_gate/drift_floor_m", &detector.odometry_gate.drift_floor_m);
  reader->read("odometry_gate/max_view_distance_m", &detector.odometry_gate.max_view_distance_m);
  VerificationOptions& verification = detector.verification;
  reader->read("verification/enabled", &verification.enabled);
  reader->read("verification/required", &verification.required);
  reader->read("verification/max_image_width", &verification.max_image_width);
  reader->read("verification/max_features", &verification.max_features);
  reader->read("verification/ratio_test", &verification.ratio_test);
  reader->read("verification/ransac_threshold_px", &verification.ransac_threshold_px);
  reader->read("verification/min_inliers", &verification.min_inliers);
  reader->read("verification/min_spread", &verification.min_spread);
  reader->read("verification/min_parallax_deg", &verification.min_parallax_deg);
  reader->read("verification/publish_scale_free_pose", &verification.publish_scale_free_pose);
  reader->read("verification/orb_levels", &verification.orb_levels);
  reader->read("verification/ambiguity_directions", &verification.ambiguity_directions);
  reader->read("verification/keypoint_sigma_px", &verification.keypoint_sigma_px);
  reader->read("verification/max_rotation_sd_deg", &verification.max_rotation_sd_deg);
  reader->read("verification/max_direction_sd_deg", &verification.max_direction_sd_deg);
  MetricPoseOptions& metric = detector.metric_pose;
  reader->read("metric_pose/triangulate_from_odometry", &metric.triangulate_from_odometry);
  reader->read("metric_pose/triangulation_keyframes", &detector.triangulation_keyframes);
  reader->read("metric_pose/min_triangulation_angle_deg", &metric.min_triangulation_angle_deg);
  reader->read("metric_pose/max_point_depth_m", &metric.max_point_depth_m);
  reader->read("metric_pose/max_reprojection_px", &metric.max_reprojection_px);
  reader->read("metric_pose/min_inliers", &metric.min_inliers);
  reader->read("metric_pose/max_translation_sd_m", &metric.max_translation_sd_m);
  reader->read("metric_pose/max_rotation_sd_deg", &metric.max_rotation_sd_deg);
  reader->read("metric_pose/depth_image_metres_per_unit", &metric.depth_image_metres_per_unit);
  reader->read("metric_pose/depth_image_sd_per_m2", &metric.depth_image_sd_per_m2);
  CameraMount& mount = detector.camera_mount;
  reader->read("camera_mount/x", &mount.x);
  reader->read("camera_mount/y", &mount.y);
  reader->read("camera_mount/z", &mount.z);
  reader->read("camera_mount/roll", &mount.roll);
  reader->read("camera_mount/pitch", &mount.pitch);
  reader->read("camera_mount/yaw", &mount.yaw);

  // Without the fetched backbone the package's own encoder runs, with its own score scale.
  std::string warning;
  const DescriptorOptions used = withBackboneFallback(detector.descriptor, &warning);
  options->fallback_warning.clear();
  if (!warning.empty()) {
    detector.descriptor = used;
    if (detector.acceptance.min_score == AcceptanceOptions().min_score) {
      detector.acceptance.min_score = kLandmarksMinScore;
      warning += " (acceptance/min_score " + std::to_string(kLandmarksMinScore).substr(0, 4) +
                 ", its tuned value)";
    }
    options->fallback_warning = warning;
  }
}

}  // namespace landmark_loop_closure
