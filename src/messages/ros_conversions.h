#pragma once

// The one place where ROS messages and core types meet.

#include <functional>
#include <optional>
#include <string>

#include <geometry_msgs/Pose.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include "landmark_loop_closure/FleetEvidence.h"
#include "landmark_loop_closure/FleetKeyframe.h"
#include "landmark_loop_closure/Keyframe.h"
#include "landmark_loop_closure/LoopCandidateArray.h"
#include "landmark_loop_closure/LoopClosure.h"
#include "landmark_loop_closure/PoseGraphLoop.h"
#include "landmark_loop_closure/backend/pose_graph_session.h"
#include "landmark_loop_closure/core/input_error.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/fleet/shared_keyframe.h"

namespace landmark_loop_closure {

/// OpenCV type (CV_8UC1, CV_16UC1, CV_8UC3, CV_8UC4) of a supported encoding; nullopt for others.
/// Supported: mono8, mono16, bgr8, rgb8, bgra8, rgba8.
std::optional<int> cvTypeOfEncoding(const std::string& encoding);

/// Checks what can be checked without touching pixels: encoding, and that the buffer holds
/// height * step bytes with step >= width * pixel size. Cheap enough for a subscriber callback.
std::optional<InputError> checkImageMessage(const sensor_msgs::Image& image);

/// 8-bit grey copy or view of a message that passed checkImageMessage.
cv::Mat toGrey(const sensor_msgs::Image& image);
/// 8-bit BGR copy of a message that passed checkImageMessage (grey is copied into all three
/// channels), for descriptors whose network takes colour.
cv::Mat toBgr(const sensor_msgs::Image& image);

/// A copy of a depth image (16UC1 or mono16: CV_16UC1 in the driver's unit; 32FC1: CV_32FC1
/// metres); an empty Mat and `error` set for other encodings or a malformed buffer, with `kind`
/// (when given) "depth_encoding" or "depth_size".
cv::Mat toDepth(const sensor_msgs::Image& image, std::string* error, std::string* kind = nullptr);

Pose fromRos(const geometry_msgs::Pose& pose);
geometry_msgs::Pose toRos(const Pose& pose);

double toSeconds(const ros::Time& stamp);

/// K, D and distortion_model (`rectified`: P and no distortion: the image is image_rect);
/// invalid (CameraIntrinsics::valid() false) for an uncalibrated camera.
CameraIntrinsics fromCameraInfo(const sensor_msgs::CameraInfo& info, bool rectified = false);

/// Stamps as double seconds lose nanoseconds at epoch scale, so messages carry the original
/// ros::Time of each keyframe, passed in by the caller.
/// `relative_pose_frame`: the frame loop.relative_pose is expressed in (named in the message).
LoopClosure toLoopMsg(const AcceptedLoop& loop, const ros::Time& query_stamp,
                      const ros::Time& match_stamp, const std::string& frame_id,
                      const std::string& relative_pose_frame);
Keyframe toKeyframeMsg(uint64_t id, uint32_t session, uint64_t map_id, const ros::Time& stamp,
                       const Pose& pose, const std::string& frame_id);
/// `stamp_of(id)` returns a keyframe's original stamp.
LoopCandidateArray toCandidatesMsg(const KeyframeResult& result, uint64_t map_id,
                                   const ros::Time& stamp, const std::string& frame_id,
                                   const std::function<ros::Time(uint64_t)>& stamp_of);
uint8_t toMsgVerdict(CandidateVerdict verdict);

/// A published loop as the pose graph takes it: ids, T_query_match and its covariance as the
/// message carries them (relative_pose_frame's frame; loopInBaseFrame turns a camera one).
GraphLoop graphLoopFromMsg(const LoopClosure& loop);
GraphKeyframe graphKeyframeFromMsg(const Keyframe& keyframe);
/// A pose graph's decision about a loop, stamped with the loop's query stamp, in `map_frame`.
PoseGraphLoop toPoseGraphLoopMsg(const GraphLoopVerdict& verdict, const std::string& map_frame);

/// Rows robots share (fleet/): the message carries the vector's scale and values apart.
FleetKeyframe toFleetKeyframeMsg(const SharedKeyframe& row);
SharedKeyframe sharedKeyframeFromMsg(const FleetKeyframe& msg);
/// A keyframe's verification data in the service's answer (replacing what it held), and back
/// (checked by KeyframeEvidence::problem() where it is used).
void toEvidenceResponse(const KeyframeEvidence& evidence, FleetEvidenceResponse* response);
KeyframeEvidence evidenceFromResponse(const FleetEvidenceRequest& request,
                                      const FleetEvidenceResponse& response);
/// Why a peer's answer is too large to convert ("" when it is not): more than `max_keypoints`
/// keypoints (or descriptors, depths for them), a thumbnail over kMaxThumbnailBytes, a problem
/// string past a log line.
std::string evidenceResponseProblem(const FleetEvidenceResponse& response, size_t max_keypoints);

}  // namespace landmark_loop_closure
