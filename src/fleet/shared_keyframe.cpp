// The rows and evidence robots exchange, read from a detector's search and map.
#include "landmark_loop_closure/fleet/shared_keyframe.h"

#include <cmath>
#include <cstring>

#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

namespace landmark_loop_closure {

namespace {

/// A camera this far from its robot's base is a corrupt mount.
constexpr double kMaxMountOffsetM = 100.0;

bool finitePose(const Pose& pose) {
  return pose.position.allFinite() && pose.orientation.coeffs().allFinite();
}

uint32_t littleEndian(const std::vector<uint8_t>& bytes, size_t at, int count) {
  uint32_t value = 0;
  for (int k = count - 1; k >= 0; --k) value = (value << 8) | bytes[at + static_cast<size_t>(k)];
  return value;
}

/// The canvas a WebP file's header declares (0 x 0 when it is not WebP or too short).
cv::Size webpHeaderSize(const std::vector<uint8_t>& bytes) {
  const auto tag = [&](size_t at, const char* text) {
    return bytes.size() >= at + 4 && std::memcmp(bytes.data() + at, text, 4) == 0;
  };
  if (bytes.size() < 30 || !tag(0, "RIFF") || !tag(8, "WEBP")) return {};
  if (tag(12, "VP8 ")) {  // Lossy: a frame tag, the start code, then 14-bit width and height.
    if (bytes[23] != 0x9d || bytes[24] != 0x01 || bytes[25] != 0x2a) return {};
    return {static_cast<int>(littleEndian(bytes, 26, 2) & 0x3fff),
            static_cast<int>(littleEndian(bytes, 28, 2) & 0x3fff)};
  }
  if (tag(12, "VP8L")) {  // Lossless: a signature byte, then 14-bit width - 1 and height - 1.
    if (bytes[20] != 0x2f) return {};
    const uint32_t bits = littleEndian(bytes, 21, 4);
    return {static_cast<int>((bits & 0x3fff) + 1), static_cast<int>(((bits >> 14) & 0x3fff) + 1)};
  }
  if (tag(12, "VP8X")) {  // Extended: flags, then 24-bit canvas width - 1 and height - 1.
    return {static_cast<int>(littleEndian(bytes, 24, 3) + 1),
            static_cast<int>(littleEndian(bytes, 27, 3) + 1)};
  }
  return {};
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
  // size, intrinsics (fx, fy, cx, cy), thumbnail, base_T_camera and its flag, the two frames.
  return 8 + 8 + 1 + 4 + (4 + 8 * points) + (4 + local_features.descriptors.total()) +
         (4 + 12 * depths) + (4 + 4 * local_features.depth_sd.size()) + 8 + 32 +
         (4 + thumbnail.size()) + 56 + 1 + (4 + base_frame.size()) + (4 + camera_frame.size());
}

std::string thumbnailProblem(const std::vector<uint8_t>& bytes) {
  if (bytes.empty()) return "";
  if (bytes.size() > kMaxThumbnailBytes) {
    return "a thumbnail of " + std::to_string(bytes.size()) + " bytes (at most " +
           std::to_string(kMaxThumbnailBytes) + ")";
  }
  const cv::Size size = webpHeaderSize(bytes);
  if (size.area() == 0) return "a thumbnail that is not WebP";
  if (size.width > kThumbnailWidth || size.height > kThumbnailHeight) {
    return "a thumbnail of " + std::to_string(size.width) + "x" + std::to_string(size.height) +
           " (at most " + std::to_string(kThumbnailWidth) + "x" + std::to_string(kThumbnailHeight) +
           ")";
  }
  return "";
}

std::string KeyframeEvidence::problem(size_t max_keypoints) const {
  const LocalFeatures& features = local_features;
  if (features.points.size() > max_keypoints) {
    return std::to_string(features.points.size()) +
           " keypoints, more than advanced/verification/max_features (" +
           std::to_string(max_keypoints) + ")";
  }
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
  // A keypoint without a depth carries NaN in all three (and its uncertainty); any other depth
  // is finite and in front of the camera.
  for (size_t k = 0; k < features.points3d.size(); ++k) {
    const cv::Point3f& point = features.points3d[k];
    const bool none = std::isnan(point.x) && std::isnan(point.y) && std::isnan(point.z);
    if (none) continue;
    if (!std::isfinite(point.x) || !std::isfinite(point.y) || !std::isfinite(point.z) ||
        !(point.z > 0.0f)) {
      return "a keypoint depth that is not finite and in front of the camera";
    }
    if (!std::isfinite(features.depth_sd[k]) || features.depth_sd[k] < 0.0f) {
      return "a depth uncertainty that is not finite";
    }
  }
  if (features.image_size.width < 0 || features.image_size.height < 0 ||
      features.image_size.width > kMaxImageSide || features.image_size.height > kMaxImageSide) {
    return "an image size of " + std::to_string(features.image_size.width) + "x" +
           std::to_string(features.image_size.height);
  }
  if (!std::isfinite(intrinsics.fx) || !std::isfinite(intrinsics.fy) ||
      !std::isfinite(intrinsics.cx) || !std::isfinite(intrinsics.cy)) {
    return "intrinsics that are not finite";
  }
  if (camera_mount &&
      (!camera_mount->position.allFinite() || !camera_mount->orientation.coeffs().allFinite() ||
       std::abs(camera_mount->orientation.norm() - 1.0) > 1e-3 ||
       camera_mount->position.cwiseAbs().maxCoeff() > kMaxMountOffsetM)) {
    return "a camera mount that is not finite, not a unit quaternion or more than " +
           std::to_string(static_cast<int>(kMaxMountOffsetM)) + " m from the base";
  }
  if (base_frame.size() > kMaxEvidenceFrameBytes || camera_frame.size() > kMaxEvidenceFrameBytes) {
    return "a frame name of more than " + std::to_string(kMaxEvidenceFrameBytes) + " bytes";
  }
  return thumbnailProblem(thumbnail);
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
  evidence.camera_mount = detector.cameraMount();
  return evidence;
}

}  // namespace landmark_loop_closure
