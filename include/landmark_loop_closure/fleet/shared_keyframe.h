// What robots exchange while they run (issue 68): each stored keyframe's compact search row,
// sent to every peer, and a keyframe's verification data, fetched only for a candidate that
// passed the score and the k-keyframe chain.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "landmark_loop_closure/geometry/camera_intrinsics.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

class LoopDetector;

/// One stored keyframe as a detector shares it: what search needs (the global vector as the map
/// keeps it: one float scale and one signed byte per value) and what a loop names.
struct SharedKeyframe {
  std::string robot;  ///< The sender's name (advanced/fleet/robot), for log lines.
  uint64_t map_id = 0;
  uint64_t id = 0;
  uint32_t session = 0;
  int64_t stamp_ns = 0;
  Pose pose;                   ///< Odometry pose of the robot base, in `odometry_frame`.
  std::string odometry_frame;  ///< The sender's odometry frame (its session's).
  /// descriptorFingerprint() of the sender's descriptor identity: rows of another descriptor
  /// (another network, PCA or standardisation) cannot be compared and are refused.
  uint64_t descriptor_fingerprint = 0;
  std::vector<uint8_t> global_row;  ///< QuantizedVectors::encode's row.

  /// Bytes on the wire as SharedKeyframe.msg carries it (header and strings included).
  size_t wireBytes() const;
  /// Why the row cannot be used ("" when it can): a vector of another length than `dimension`,
  /// a non-finite scale or pose, an empty robot name.
  std::string problem(int dimension) const;
};

/// FNV-1a of a detector's descriptor identity (LoopDetector::descriptorIdentity()).
uint64_t descriptorFingerprint(const std::string& identity);

/// A shared keyframe's verification data: its ORB keypoints (with their depths, for a metric
/// pose) and its thumbnail (the appearance check), with the intrinsics of the camera that took it.
struct KeyframeEvidence {
  uint64_t map_id = 0;
  uint64_t id = 0;
  LocalFeatures local_features;
  CameraIntrinsics intrinsics;
  std::vector<uint8_t> thumbnail;
  /// Where the camera sits on the answering robot's base (base_T_camera); absent: not known yet.
  std::optional<Pose> camera_mount;
  std::string base_frame;    ///< The answering robot's base frame.
  std::string camera_frame;  ///< Its camera's optical frame.

  /// Bytes on the wire as the keyframe_evidence service answers it.
  size_t wireBytes() const;
  /// Why it cannot be checked against ("" when it can). It comes from another process and is
  /// validated whole before anything decodes or matches it: at most `max_keypoints` keypoints
  /// (advanced/verification/max_features), each with a 32-byte descriptor, finite; depths of
  /// the same count, each NaN (none) or finite and in front of the camera with a finite
  /// uncertainty; finite intrinsics; a camera mount, when given, finite with a unit quaternion;
  /// frame names of at most kMaxEvidenceFrameBytes; a thumbnail as thumbnailProblem() allows.
  std::string problem(size_t max_keypoints) const;
};

/// The thumbnail a detector shares (makeThumbnail): WebP, at most this size and these bytes.
constexpr int kThumbnailWidth = 160;
constexpr int kThumbnailHeight = 120;
constexpr size_t kMaxThumbnailBytes = 64 * 1024;
/// Longest image side evidence may name.
constexpr int kMaxImageSide = 16384;
/// Longest frame name evidence may carry.
constexpr size_t kMaxEvidenceFrameBytes = 256;

/// Why `bytes` cannot be a shared thumbnail ("" when it can, or is empty): over
/// kMaxThumbnailBytes, not WebP, or a canvas larger than kThumbnailWidth x kThumbnailHeight, read
/// from its header before anything is decoded.
std::string thumbnailProblem(const std::vector<uint8_t>& bytes);

/// Worker thread: stored keyframe `id` of `detector` as it is shared; nullopt when it is not in
/// search (past the memory budget, or unknown).
std::optional<SharedKeyframe> sharedKeyframeOf(const LoopDetector& detector, uint64_t id,
                                               const std::string& robot,
                                               const std::string& odometry_frame);
/// Worker thread: keyframe `id`'s verification data, with the detector's camera mount where it is
/// known; nullopt when its record cannot be read.
std::optional<KeyframeEvidence> evidenceOf(const LoopDetector& detector, uint64_t id,
                                           const CameraIntrinsics& intrinsics);

}  // namespace landmark_loop_closure
