// The rows and evidence robots exchange, read from a detector's search and map.
#include "landmark_loop_closure/fleet/shared_keyframe.h"

#include <cmath>
#include <cstring>

#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

namespace landmark_loop_closure {

namespace {

bool finitePose(const Pose& pose) {
  return pose.position.allFinite() && pose.orientation.coeffs().allFinite();
}

}  // namespace

size_t SharedKeyframe::wireBytes() const {
  // Header (seq, stamp, frame_id), robot, map_id, id, session, pose (7 doubles), fingerprint,
  // the vector's scale and its values; strings and arrays carry a 4-byte length.
  return 4 + 8 + 4 + odometry_frame.size() + 4 + robot.size() + 8 + 8 + 4 + 56 + 8 + 4 + 4 +
         (global_row.size() >= sizeof(float) ? global_row.size() - sizeof(float) : 0);
}

std::string SharedKeyframe::problem(int dimension) const {
  if (robot.empty()) return "no robot name";
  if (global_row.size() != sizeof(float) + static_cast<size_t>(dimension)) {
    const long values = static_cast<long>(global_row.size()) - static_cast<long>(sizeof(float));
    return "a global vector of " + std::to_string(values < 0 ? 0 : values) +
           " values where this detector's have " + std::to_string(dimension);
  }
  float scale = 0.0f;
  std::memcpy(&scale, global_row.data(), sizeof(float));
  if (!std::isfinite(scale) || scale < 0.0f) return "a global vector scale that is not finite";
  if (!finitePose(pose)) return "a pose that is not finite";
  const double norm = pose.orientation.norm();
  if (std::abs(norm - 1.0) > 1e-3) return "an orientation that is not a unit quaternion";
  return "";
}

uint64_t descriptorFingerprint(const std::string& identity) {
  uint64_t hash = 14695981039346656037ull;
  for (const unsigned char c : identity) {
    hash ^= c;
    hash *= 1099511628211ull;
  }
  return hash;
}

size_t KeyframeEvidence::wireBytes() const {
  const size_t points = local_features.points.size();
  const size_t depths = local_features.points3d.size();
  // map_id, id, found, problem (empty), points (x, y), descriptors, points3d, depth_sd, image
  // size, intrinsics (fx, fy, cx, cy), thumbnail.
  return 8 + 8 + 1 + 4 + (4 + 8 * points) + (4 + local_features.descriptors.total()) +
         (4 + 12 * depths) + (4 + 4 * local_features.depth_sd.size()) + 8 + 32 +
         (4 + thumbnail.size());
}

std::string KeyframeEvidence::problem() const {
  const LocalFeatures& features = local_features;
  if (!features.points.empty() &&
      (features.descriptors.type() != CV_8U || features.descriptors.cols != 32 ||
       static_cast<size_t>(features.descriptors.rows) != features.points.size())) {
    return std::to_string(features.points.size()) + " keypoints without a 32-byte descriptor each";
  }
  if (!features.points3d.empty() && features.points3d.size() != features.points.size()) {
    return std::to_string(features.points3d.size()) + " keypoint depths for " +
           std::to_string(features.points.size()) + " keypoints";
  }
  if (features.depth_sd.size() != features.points3d.size()) {
    return "depth uncertainties of another count than the depths";
  }
  for (const cv::Point2f& point : features.points) {
    if (!std::isfinite(point.x) || !std::isfinite(point.y)) return "a keypoint that is not finite";
  }
  return "";
}

std::optional<SharedKeyframe> sharedKeyframeOf(const LoopDetector& detector, uint64_t id,
                                               const std::string& robot,
                                               const std::string& odometry_frame) {
  const KeyframeDatabase& database = detector.database();
  const std::optional<size_t> index = database.indexOf(id);
  if (!index || !database.vectors()) return std::nullopt;
  const KeyframeSummary& summary = database.summary(*index);
  SharedKeyframe shared;
  shared.robot = robot;
  shared.map_id = detector.map().mapId();
  shared.id = id;
  shared.session = summary.session;
  shared.stamp_ns = detector.map().keyframeStampNs(id).value_or(
      static_cast<int64_t>(std::llround(summary.stamp * 1e9)));
  shared.pose = summary.pose;
  shared.odometry_frame = odometry_frame;
  shared.descriptor_fingerprint = descriptorFingerprint(detector.descriptorIdentity());
  const QuantizedVectors& vectors = *database.vectors();
  const uint8_t* row = vectors.row(*index);
  shared.global_row.assign(row, row + vectors.rowBytes());
  return shared;
}

std::optional<KeyframeEvidence> evidenceOf(const LoopDetector& detector, uint64_t id,
                                           const CameraIntrinsics& intrinsics) {
  const std::shared_ptr<const KeyframeRecord> record = detector.database().findRecord(id);
  if (!record) return std::nullopt;
  KeyframeEvidence evidence;
  evidence.map_id = detector.map().mapId();
  evidence.id = id;
  evidence.local_features = record->local_features;
  evidence.intrinsics = intrinsics;
  evidence.thumbnail = record->thumbnail;
  return evidence;
}

}  // namespace landmark_loop_closure
