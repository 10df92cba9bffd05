#include "messages/ros_conversions.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

#include <sensor_msgs/image_encodings.h>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

namespace landmark_loop_closure {

namespace enc = sensor_msgs::image_encodings;

std::optional<int> cvTypeOfEncoding(const std::string& encoding) {
  if (encoding == enc::MONO8) return CV_8UC1;
  if (encoding == enc::MONO16) return CV_16UC1;
  if (encoding == enc::BGR8 || encoding == enc::RGB8) return CV_8UC3;
  if (encoding == enc::BGRA8 || encoding == enc::RGBA8) return CV_8UC4;
  return std::nullopt;
}

std::optional<InputError> checkImageMessage(const sensor_msgs::Image& image) {
  const std::optional<int> type = cvTypeOfEncoding(image.encoding);
  if (!type) {
    return InputError{InputErrorCode::kUnsupportedImageType,
                      "image encoding '" + image.encoding +
                          "' is not supported (use mono8, mono16, bgr8, rgb8, bgra8 or rgba8)"};
  }
  if (image.header.stamp.isZero()) {
    return InputError{InputErrorCode::kUnsetStamp,
                      "image stamp is 0: the camera driver left header.stamp unset, so the frame "
                      "cannot be placed in time"};
  }
  if (image.width == 0 || image.height == 0) {
    std::ostringstream message;
    message << "image is empty (" << image.width << "x" << image.height << ")";
    return InputError{InputErrorCode::kEmptyImage, message.str()};
  }
  const size_t pixel_bytes = CV_ELEM_SIZE(*type);
  const size_t needed = static_cast<size_t>(image.step) * image.height;
  if (image.step < image.width * pixel_bytes || image.data.size() < needed) {
    std::ostringstream message;
    message << "image " << image.width << "x" << image.height << " " << image.encoding
            << " has step " << image.step << " and " << image.data.size()
            << " bytes of data, which cannot hold it";
    return InputError{InputErrorCode::kMalformedImage, message.str()};
  }
  // Rows of 16-bit samples must start on a sample: OpenCV cannot view them otherwise.
  if (image.step % CV_ELEM_SIZE1(*type) != 0) {
    std::ostringstream message;
    message << "image " << image.encoding << " has step " << image.step
            << ", not a multiple of its " << CV_ELEM_SIZE1(*type) << "-byte samples";
    return InputError{InputErrorCode::kMalformedImage, message.str()};
  }
  return std::nullopt;
}

namespace {

// A view of a checked message's buffer; callers copy before the message can go away.
cv::Mat pixelView(const sensor_msgs::Image& image) {
  return cv::Mat(static_cast<int>(image.height), static_cast<int>(image.width),
                 *cvTypeOfEncoding(image.encoding), const_cast<uint8_t*>(image.data.data()),
                 image.step);
}

}  // namespace

cv::Mat toGrey(const sensor_msgs::Image& image) {
  const cv::Mat view = pixelView(image);
  cv::Mat grey;
  if (image.encoding == enc::MONO8) {
    grey = view.clone();
  } else if (image.encoding == enc::MONO16) {
    view.convertTo(grey, CV_8U, 1.0 / 256.0);
  } else if (image.encoding == enc::BGR8) {
    cv::cvtColor(view, grey, cv::COLOR_BGR2GRAY);
  } else if (image.encoding == enc::RGB8) {
    cv::cvtColor(view, grey, cv::COLOR_RGB2GRAY);
  } else if (image.encoding == enc::BGRA8) {
    cv::cvtColor(view, grey, cv::COLOR_BGRA2GRAY);
  } else {
    cv::cvtColor(view, grey, cv::COLOR_RGBA2GRAY);
  }
  return grey;
}

cv::Mat toBgr(const sensor_msgs::Image& image) {
  const cv::Mat view = pixelView(image);
  cv::Mat bgr;
  if (image.encoding == enc::MONO8 || image.encoding == enc::MONO16) {
    cv::cvtColor(toGrey(image), bgr, cv::COLOR_GRAY2BGR);
  } else if (image.encoding == enc::BGR8) {
    bgr = view.clone();
  } else if (image.encoding == enc::RGB8) {
    cv::cvtColor(view, bgr, cv::COLOR_RGB2BGR);
  } else if (image.encoding == enc::BGRA8) {
    cv::cvtColor(view, bgr, cv::COLOR_BGRA2BGR);
  } else {
    cv::cvtColor(view, bgr, cv::COLOR_RGBA2BGR);
  }
  return bgr;
}

cv::Mat toDepth(const sensor_msgs::Image& image, std::string* error, std::string* kind) {
  int type = -1;
  if (image.encoding == enc::TYPE_16UC1 || image.encoding == enc::MONO16) type = CV_16UC1;
  if (image.encoding == enc::TYPE_32FC1) type = CV_32FC1;
  if (type < 0) {
    *error = "depth encoding '" + image.encoding + "' is not 16UC1, mono16 or 32FC1";
    if (kind != nullptr) *kind = "depth_encoding";
    return {};
  }
  const size_t row_bytes = static_cast<size_t>(image.width) * CV_ELEM_SIZE(type);
  if (image.width == 0 || image.height == 0 || image.step < row_bytes ||
      image.step % CV_ELEM_SIZE(type) != 0 ||
      image.data.size() < static_cast<size_t>(image.step) * image.height) {
    *error = "depth image " + std::to_string(image.width) + "x" + std::to_string(image.height) +
             " with step " + std::to_string(image.step) + " does not fit its " +
             std::to_string(image.data.size()) + "-byte buffer";
    if (kind != nullptr) *kind = "depth_size";
    return {};
  }
  const cv::Mat view(static_cast<int>(image.height), static_cast<int>(image.width), type,
                     const_cast<uint8_t*>(image.data.data()), image.step);
  return view.clone();
}

Pose fromRos(const geometry_msgs::Pose& pose) {
  Pose result;
  result.position = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  // Not normalised here: checkPose decides whether the quaternion is close enough to unit.
  result.orientation = Eigen::Quaterniond(pose.orientation.w, pose.orientation.x,
                                          pose.orientation.y, pose.orientation.z);
  return result;
}

geometry_msgs::Pose toRos(const Pose& pose) {
  geometry_msgs::Pose result;
  result.position.x = pose.position.x();
  result.position.y = pose.position.y();
  result.position.z = pose.position.z();
  result.orientation.w = pose.orientation.w();
  result.orientation.x = pose.orientation.x();
  result.orientation.y = pose.orientation.y();
  result.orientation.z = pose.orientation.z();
  return result;
}

double toSeconds(const ros::Time& stamp) { return stamp.toSec(); }

LoopClosure toLoopMsg(const AcceptedLoop& loop, const ros::Time& query_stamp,
                      const ros::Time& match_stamp, const std::string& frame_id,
                      const std::string& relative_pose_frame) {
  LoopClosure msg;
  msg.header.stamp = query_stamp;
  msg.header.frame_id = frame_id;
  msg.map_id = loop.map_id;
  msg.match_map_id = loop.match_map_id != 0 ? loop.match_map_id : loop.map_id;
  msg.match_frame_id = loop.match_map_id != 0 ? loop.match_odometry_frame : frame_id;
  msg.query_id = loop.query_id;
  msg.query_session = loop.query_session;
  msg.match_session = loop.match_session;
  msg.query_stamp = query_stamp;
  msg.match_id = loop.match_id;
  msg.match_stamp = match_stamp;
  msg.score = loop.score;
  msg.global_score = loop.global_score;
  msg.rerank_score = loop.rerank_score;
  msg.consistent_frames = static_cast<uint32_t>(loop.consistent_keyframes);
  msg.query_pose = toRos(loop.query_pose);
  msg.match_pose = toRos(loop.match_pose);
  msg.match_camera_mount.orientation.w = 1.0;
  if (loop.match_camera_mount) {
    msg.match_camera_mount = toRos(*loop.match_camera_mount);
    msg.has_match_camera_mount = true;
  }
  msg.relative_pose.pose.orientation.w = 1.0;
  msg.has_relative_pose = false;
  if (loop.verification && loop.verification->placeConfirmed()) {
    const VerificationResult& check = *loop.verification;
    msg.verified = true;
    msg.inliers = static_cast<uint32_t>(check.inliers);
    msg.reprojection_error = check.rms_error_px;
    if (loop.metric_pose && loop.metric_pose->found) {
      msg.inliers = static_cast<uint32_t>(loop.metric_pose->inliers);
      msg.reprojection_error = loop.metric_pose->rms_error_px;
    }
  }
  if (loop.appearance && loop.appearance->confirmed) {
    msg.appearance_verified = true;
    msg.appearance_inliers = static_cast<uint32_t>(loop.appearance->inliers);
  }
  if (loop.relative_pose) {
    const RelativePose& relative = *loop.relative_pose;
    msg.relative_pose.pose.position.x = relative.translation.x();
    msg.relative_pose.pose.position.y = relative.translation.y();
    msg.relative_pose.pose.position.z = relative.translation.z();
    const Eigen::Quaterniond rotation(relative.rotation);
    msg.relative_pose.pose.orientation.w = rotation.w();
    msg.relative_pose.pose.orientation.x = rotation.x();
    msg.relative_pose.pose.orientation.y = rotation.y();
    msg.relative_pose.pose.orientation.z = rotation.z();
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) {
        msg.relative_pose.covariance[static_cast<size_t>(r * 6 + c)] = relative.covariance(r, c);
      }
    }
    msg.has_relative_pose = true;
    msg.relative_pose_metric = relative.metric;
    msg.relative_pose_frame = relative_pose_frame;
  }
  return msg;
}

CameraIntrinsics fromCameraInfo(const sensor_msgs::CameraInfo& info, bool rectified) {
  CameraIntrinsics intrinsics;
  intrinsics.image_size = cv::Size(static_cast<int>(info.width), static_cast<int>(info.height));
  if (rectified) {
    // image_rect: P's left 3x3 is the rectified camera; no lens model is left to apply.
    intrinsics.fx = info.P[0];
    intrinsics.cx = info.P[2];
    intrinsics.fy = info.P[5];
    intrinsics.cy = info.P[6];
    return intrinsics;
  }
  intrinsics.fx = info.K[0];
  intrinsics.cx = info.K[2];
  intrinsics.fy = info.K[4];
  intrinsics.cy = info.K[5];
  intrinsics.setLens(info.distortion_model, std::vector<double>(info.D.begin(), info.D.end()));
  return intrinsics;
}

Keyframe toKeyframeMsg(uint64_t id, uint32_t session, uint64_t map_id, const ros::Time& stamp,
                       const Pose& pose, const std::string& frame_id) {
  Keyframe msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = frame_id;
  msg.map_id = map_id;
  msg.id = id;
  msg.session = session;
  msg.pose = toRos(pose);
  return msg;
}

uint8_t toMsgVerdict(CandidateVerdict verdict) {
  switch (verdict) {
    case CandidateVerdict::kAccepted:
      return LoopCandidate::ACCEPTED;
    case CandidateVerdict::kBelowThreshold:
      return LoopCandidate::BELOW_THRESHOLD;
    case CandidateVerdict::kAwaitingConsistency:
      return LoopCandidate::AWAITING_CONSISTENCY;
    case CandidateVerdict::kOutscored:
      return LoopCandidate::OUTSCORED;
    case CandidateVerdict::kOdometryRejected:
      return LoopCandidate::ODOMETRY_REJECTED;
    case CandidateVerdict::kGeometryRejected:
      return LoopCandidate::GEOMETRY_REJECTED;
    case CandidateVerdict::kUnreadable:
      return LoopCandidate::UNREADABLE;
    case CandidateVerdict::kAmbiguous:
      return LoopCandidate::AMBIGUOUS;
  }
  return LoopCandidate::BELOW_THRESHOLD;
}

LoopCandidateArray toCandidatesMsg(const KeyframeResult& result, uint64_t map_id,
                                   const ros::Time& stamp, const std::string& frame_id,
                                   const std::function<ros::Time(uint64_t)>& stamp_of) {
  LoopCandidateArray msg;
  msg.header.stamp = stamp;
  msg.header.frame_id = frame_id;
  msg.map_id = map_id;
  msg.query_id = result.keyframe_id;
  msg.query_status = toString(result.query_status);
  for (const CandidateReport& report : result.candidates) {
    LoopCandidate candidate;
    candidate.match_id = report.match_id;
    candidate.match_stamp = stamp_of(report.match_id);
    candidate.score = report.score;
    candidate.global_score = report.global_score;
    candidate.consistent_frames = static_cast<uint32_t>(report.consistent_keyframes);
    candidate.verdict = toMsgVerdict(report.verdict);
    candidate.reason = toString(report.verdict);
    if (!report.detail.empty()) candidate.reason += ": " + report.detail;
    candidate.inliers = static_cast<uint32_t>(report.inliers);
    candidate.place_ratio = report.place_ratio;
    msg.candidates.push_back(candidate);
  }
  return msg;
}

GraphLoop graphLoopFromMsg(const LoopClosure& loop) {
  GraphLoop graph_loop;
  graph_loop.map_id = loop.map_id;
  graph_loop.match_map_id = loop.match_map_id;
  graph_loop.query_session = loop.query_session;
  graph_loop.match_session = loop.match_session;
  graph_loop.query_stamp_ns = loop.query_stamp.toNSec();
  graph_loop.match_stamp_ns = loop.match_stamp.toNSec();
  graph_loop.has_relative_pose = loop.has_relative_pose;
  graph_loop.relative_pose_metric = loop.relative_pose_metric;
  graph_loop.relative_pose_frame = loop.relative_pose_frame;
  LoopConstraint& constraint = graph_loop.constraint;
  constraint.query_id = loop.query_id;
  constraint.match_id = loop.match_id;
  const Pose relative = fromRos(loop.relative_pose.pose);
  // Not normalised: the graph refuses a quaternion that is not of unit length.
  constraint.query_T_match.linear() = scaledRotationMatrix(relative.orientation);
  constraint.query_T_match.translation() = relative.position;
  constraint.covariance = Eigen::Map<const Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(
      loop.relative_pose.covariance.data());
  if (loop.has_match_camera_mount) {
    const Pose mount = fromRos(loop.match_camera_mount);
    Eigen::Isometry3d match_mount = Eigen::Isometry3d::Identity();
    match_mount.linear() = scaledRotationMatrix(mount.orientation);  // Checked by the graph.
    match_mount.translation() = mount.position;
    graph_loop.match_camera_mount = match_mount;
  }
  return graph_loop;
}

GraphKeyframe graphKeyframeFromMsg(const Keyframe& keyframe) {
  GraphKeyframe graph_keyframe;
  graph_keyframe.id = keyframe.id;
  graph_keyframe.map_id = keyframe.map_id;
  graph_keyframe.session = keyframe.session;
  graph_keyframe.odometry = fromRos(keyframe.pose);
  graph_keyframe.stamp_ns = keyframe.header.stamp.toNSec();
  graph_keyframe.odometry_frame = keyframe.header.frame_id;
  return graph_keyframe;
}

PoseGraphLoop toPoseGraphLoopMsg(const GraphLoopVerdict& verdict, const std::string& map_frame) {
  PoseGraphLoop msg;
  msg.query_stamp.fromNSec(verdict.loop.query_stamp_ns);
  msg.match_stamp.fromNSec(verdict.loop.match_stamp_ns);
  msg.header.stamp = msg.query_stamp;
  msg.header.frame_id = map_frame;
  msg.map_id = verdict.loop.map_id;
  msg.match_map_id = verdict.loop.match_map_id;
  msg.query_id = verdict.loop.constraint.query_id;
  msg.match_id = verdict.loop.constraint.match_id;
  msg.decision = verdict.decision;
  msg.error_sd = verdict.error_sd;
  msg.detail = verdict.detail;
  return msg;
}

}  // namespace landmark_loop_closure

namespace landmark_loop_closure {

FleetKeyframe toFleetKeyframeMsg(const SharedKeyframe& row) {
  FleetKeyframe msg;
  msg.header.stamp.fromNSec(static_cast<uint64_t>(std::max<int64_t>(row.stamp_ns, 0)));
  msg.header.frame_id = row.odometry_frame;
  msg.robot = row.robot;
  msg.map_id = row.map_id;
  msg.id = row.id;
  msg.session = row.session;
  msg.pose = toRos(row.pose);
  msg.descriptor_fingerprint = row.descriptor_fingerprint;
  if (row.global_row.size() >= sizeof(float)) {
    std::memcpy(&msg.global_scale, row.global_row.data(), sizeof(float));
    msg.global_values.resize(row.global_row.size() - sizeof(float));
    std::memcpy(msg.global_values.data(), row.global_row.data() + sizeof(float),
                msg.global_values.size());
  }
  return msg;
}

SharedKeyframe sharedKeyframeFromMsg(const FleetKeyframe& msg) {
  SharedKeyframe row;
  row.robot = msg.robot;
  row.map_id = msg.map_id;
  row.id = msg.id;
  row.session = msg.session;
  row.stamp_ns = static_cast<int64_t>(msg.header.stamp.toNSec());
  row.odometry_frame = msg.header.frame_id;
  row.pose = fromRos(msg.pose);  // SharedKeyframe::problem() refuses a non-unit orientation.
  row.descriptor_fingerprint = msg.descriptor_fingerprint;
  row.global_row.resize(sizeof(float) + msg.global_values.size());
  std::memcpy(row.global_row.data(), &msg.global_scale, sizeof(float));
  std::memcpy(row.global_row.data() + sizeof(float), msg.global_values.data(),
              msg.global_values.size());
  return row;
}

void toEvidenceResponse(const KeyframeEvidence& evidence, FleetEvidenceResponse* response) {
  const LocalFeatures& features = evidence.local_features;
  *response = FleetEvidenceResponse();
  response->found = true;
  response->keypoints.reserve(2 * features.points.size());
  for (const cv::Point2f& point : features.points) {
    response->keypoints.push_back(point.x);
    response->keypoints.push_back(point.y);
  }
  if (!features.descriptors.empty()) {
    const cv::Mat descriptors =
        features.descriptors.isContinuous() ? features.descriptors : features.descriptors.clone();
    response->descriptors.assign(descriptors.data, descriptors.data + descriptors.total());
  }
  for (const cv::Point3f& point : features.points3d) {
    response->points3d.push_back(point.x);
    response->points3d.push_back(point.y);
    response->points3d.push_back(point.z);
  }
  response->depth_sd = features.depth_sd;
  response->image_width = static_cast<uint32_t>(std::max(features.image_size.width, 0));
  response->image_height = static_cast<uint32_t>(std::max(features.image_size.height, 0));
  response->intrinsics = {evidence.intrinsics.fx, evidence.intrinsics.fy, evidence.intrinsics.cx,
                          evidence.intrinsics.cy};
  response->thumbnail = evidence.thumbnail;
  response->base_T_camera.orientation.w = 1.0;
  if (evidence.camera_mount) {
    response->base_T_camera = toRos(*evidence.camera_mount);
    response->has_base_T_camera = true;
  }
  response->base_frame = evidence.base_frame;
  response->camera_frame = evidence.camera_frame;
}

KeyframeEvidence evidenceFromResponse(const FleetEvidenceRequest& request,
                                      const FleetEvidenceResponse& response) {
  KeyframeEvidence evidence;
  evidence.map_id = request.map_id;
  evidence.id = request.id;
  LocalFeatures& features = evidence.local_features;
  for (size_t k = 0; k + 1 < response.keypoints.size(); k += 2) {
    features.points.emplace_back(response.keypoints[k], response.keypoints[k + 1]);
  }
  // A length that does not fit the keypoints is kept as it is, for problem() to refuse.
  const int rows = static_cast<int>(response.descriptors.size() / 32);
  if (response.descriptors.size() % 32 == 0 && rows > 0) {
    features.descriptors = cv::Mat(rows, 32, CV_8U);
    std::memcpy(features.descriptors.data, response.descriptors.data(),
                response.descriptors.size());
  } else if (!response.descriptors.empty()) {
    features.descriptors = cv::Mat(1, static_cast<int>(response.descriptors.size()), CV_8U);
    std::memcpy(features.descriptors.data, response.descriptors.data(),
                response.descriptors.size());
  }
  for (size_t k = 0; k + 2 < response.points3d.size(); k += 3) {
    features.points3d.emplace_back(response.points3d[k], response.points3d[k + 1],
                                   response.points3d[k + 2]);
  }
  features.depth_sd = response.depth_sd;
  features.image_size =
      cv::Size(static_cast<int>(response.image_width), static_cast<int>(response.image_height));
  evidence.intrinsics.fx = response.intrinsics[0];
  evidence.intrinsics.fy = response.intrinsics[1];
  evidence.intrinsics.cx = response.intrinsics[2];
  evidence.intrinsics.cy = response.intrinsics[3];
  evidence.intrinsics.image_size = features.image_size;
  evidence.thumbnail = response.thumbnail;
  // Not normalised: problem() refuses a quaternion that is not of unit length.
  if (response.has_base_T_camera) evidence.camera_mount = fromRos(response.base_T_camera);
  evidence.base_frame = response.base_frame;
  evidence.camera_frame = response.camera_frame;
  return evidence;
}

std::string evidenceResponseProblem(const FleetEvidenceResponse& response, size_t max_keypoints) {
  const auto over = [&](size_t count, size_t per_keypoint) {
    return count > per_keypoint * max_keypoints;
  };
  if (over(response.keypoints.size(), 2) || over(response.descriptors.size(), 32) ||
      over(response.points3d.size(), 3) || over(response.depth_sd.size(), 1)) {
    return std::to_string(response.keypoints.size() / 2) +
           " keypoints (or their descriptors or depths), more than "
           "advanced/verification/max_features (" +
           std::to_string(max_keypoints) + ")";
  }
  if (response.thumbnail.size() > kMaxThumbnailBytes) {
    return "a thumbnail of " + std::to_string(response.thumbnail.size()) + " bytes (at most " +
           std::to_string(kMaxThumbnailBytes) + ")";
  }
  constexpr size_t kMaxProblemBytes = 512;
  if (response.problem.size() > kMaxProblemBytes) {
    return "a problem text of " + std::to_string(response.problem.size()) + " bytes";
  }
  if (response.base_frame.size() > kMaxEvidenceFrameBytes ||
      response.camera_frame.size() > kMaxEvidenceFrameBytes) {
    return "a frame name of more than " + std::to_string(kMaxEvidenceFrameBytes) + " bytes";
  }
  return "";
}

}  // namespace landmark_loop_closure
