// The messages robots exchange (FleetKeyframe.msg, FleetEvidence.srv) and their conversions.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>

#include "../../src/messages/ros_conversions.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

using namespace landmark_loop_closure;

// What robots exchange survives the messages unchanged, and a malformed answer is caught by the
// checks the receiver runs (SharedKeyframe::problem, KeyframeEvidence::problem).
TEST(FleetMessages, SharedRowsAndEvidenceRoundTripAndMalformedOnesAreCaught) {
  SharedKeyframe row;
  row.robot = "robot_a";
  row.map_id = 77;
  row.id = 12;
  row.session = 2;
  row.stamp_ns = 1700000000123456789;
  row.pose = Pose::fromIsometry(Eigen::Translation3d(1.0, 2.0, 0.0) *
                                Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  row.odometry_frame = "robot_a/odom";
  row.descriptor_fingerprint = descriptorFingerprint("identity");
  row.global_row = QuantizedVectors::encode(std::vector<float>{0.6f, -0.8f, 0.0f});
  const SharedKeyframe back = sharedKeyframeFromMsg(toFleetKeyframeMsg(row));
  EXPECT_EQ(back.robot, row.robot);
  EXPECT_EQ(back.map_id, row.map_id);
  EXPECT_EQ(back.id, row.id);
  EXPECT_EQ(back.session, row.session);
  EXPECT_EQ(back.stamp_ns, row.stamp_ns);
  EXPECT_EQ(back.odometry_frame, row.odometry_frame);
  EXPECT_EQ(back.descriptor_fingerprint, row.descriptor_fingerprint);
  EXPECT_EQ(back.global_row, row.global_row);
  EXPECT_TRUE(back.pose.toIsometry().isApprox(row.pose.toIsometry(), 1e-12));
  EXPECT_EQ(back.problem(3), "");
  EXPECT_EQ(toFleetKeyframeMsg(row).global_values.size(), 3u);

  FleetKeyframe zero_orientation = toFleetKeyframeMsg(row);
  zero_orientation.pose.orientation = geometry_msgs::Quaternion();
  zero_orientation.pose.orientation.w = 0.0;
  EXPECT_NE(sharedKeyframeFromMsg(zero_orientation).problem(3).find("unit quaternion"),
            std::string::npos);

  KeyframeEvidence evidence;
  evidence.map_id = 77;
  evidence.id = 12;
  evidence.local_features.points = {{10.5f, 20.25f}, {30.0f, 40.0f}};
  evidence.local_features.descriptors = cv::Mat(2, 32, CV_8U, cv::Scalar(7));
  evidence.local_features.points3d = {{0.1f, 0.2f, 3.0f}, {NAN, NAN, NAN}};
  evidence.local_features.depth_sd = {0.05f, NAN};
  evidence.local_features.image_size = cv::Size(640, 480);
  evidence.intrinsics.fx = evidence.intrinsics.fy = 500.0;
  evidence.intrinsics.cx = 320.0;
  evidence.intrinsics.cy = 240.0;
  evidence.thumbnail = makeThumbnail(cv::Mat(480, 640, CV_8U, cv::Scalar(90)));
  FleetEvidence::Response response;
  toEvidenceResponse(evidence, &response);
  FleetEvidence::Request request;
  request.map_id = 77;
  request.id = 12;
  const KeyframeEvidence received = evidenceFromResponse(request, response);
  EXPECT_EQ(received.problem(400), "");
  EXPECT_EQ(received.local_features.points, evidence.local_features.points);
  EXPECT_EQ(cv::norm(received.local_features.descriptors, evidence.local_features.descriptors,
                     cv::NORM_HAMMING),
            0.0);
  EXPECT_EQ(received.local_features.points3d[0], evidence.local_features.points3d[0]);
  EXPECT_TRUE(std::isnan(received.local_features.points3d[1].z));
  EXPECT_EQ(received.local_features.image_size, evidence.local_features.image_size);
  EXPECT_EQ(received.intrinsics.fx, 500.0);
  EXPECT_EQ(received.intrinsics.cy, 240.0);
  EXPECT_EQ(received.thumbnail, evidence.thumbnail);
  EXPECT_FALSE(received.camera_mount);  // The answering robot did not know it.

  // The answering robot's mount and frames come with its evidence (the match's end of a loop
  // between two differently mounted robots).
  CameraMount mount;
  mount.x = 0.3;
  mount.pitch = 0.17;
  evidence.camera_mount = mount.toPose();
  evidence.base_frame = "robot_a/base_link";
  evidence.camera_frame = "robot_a/camera";
  toEvidenceResponse(evidence, &response);
  const KeyframeEvidence mounted = evidenceFromResponse(request, response);
  EXPECT_EQ(mounted.problem(400), "");
  ASSERT_TRUE(mounted.camera_mount);
  EXPECT_TRUE(mounted.camera_mount->toIsometry().isApprox(mount.toPose().toIsometry(), 1e-12));
  EXPECT_EQ(mounted.base_frame, "robot_a/base_link");
  EXPECT_EQ(mounted.camera_frame, "robot_a/camera");
  response.base_T_camera.orientation.w = 0.0;  // Not a unit quaternion.
  EXPECT_NE(evidenceFromResponse(request, response).problem(400).find("camera mount"),
            std::string::npos);
  toEvidenceResponse(evidence, &response);
  response.base_T_camera.position.x = NAN;
  EXPECT_NE(evidenceFromResponse(request, response).problem(400).find("camera mount"),
            std::string::npos);
  toEvidenceResponse(evidence, &response);
  response.camera_frame.assign(1000, 'c');
  EXPECT_NE(evidenceResponseProblem(response, 400).find("frame name"), std::string::npos);
  evidence.camera_mount.reset();
  evidence.base_frame.clear();
  evidence.camera_frame.clear();
  toEvidenceResponse(evidence, &response);

  response.descriptors.resize(40);  // Not 32 bytes a keypoint.
  EXPECT_NE(evidenceFromResponse(request, response).problem(400).find("32-byte descriptor"),
            std::string::npos);
  toEvidenceResponse(evidence, &response);
  response.points3d.resize(3);  // One depth for two keypoints.
  EXPECT_NE(evidenceFromResponse(request, response).problem(400).find("keypoint depths"),
            std::string::npos);
}

// A peer's evidence is validated whole before anything decodes or matches it.
TEST(FleetMessages, EvidenceOutsideItsLimitsIsRefusedBeforeItIsDecoded) {
  KeyframeEvidence evidence;
  evidence.local_features.points = {{10.5f, 20.25f}, {30.0f, 40.0f}};
  evidence.local_features.descriptors = cv::Mat(2, 32, CV_8U, cv::Scalar(7));
  evidence.local_features.points3d = {{0.1f, 0.2f, 3.0f}, {NAN, NAN, NAN}};
  evidence.local_features.depth_sd = {0.05f, NAN};
  evidence.local_features.image_size = cv::Size(640, 480);
  evidence.intrinsics.fx = evidence.intrinsics.fy = 500.0;
  evidence.thumbnail = makeThumbnail(cv::Mat(480, 640, CV_8U, cv::Scalar(90)));
  ASSERT_EQ(evidence.problem(400), "");
  EXPECT_NE(evidence.problem(1).find("2 keypoints, more than advanced/verification/max_features"),
            std::string::npos);

  KeyframeEvidence behind = evidence;
  behind.local_features.points3d[0].z = -1.0f;
  EXPECT_NE(behind.problem(400).find("in front of the camera"), std::string::npos);
  KeyframeEvidence infinite = evidence;
  infinite.local_features.points3d[0].x = INFINITY;
  EXPECT_NE(infinite.problem(400).find("not finite"), std::string::npos);
  KeyframeEvidence bad_sd = evidence;
  bad_sd.local_features.depth_sd[0] = NAN;
  EXPECT_NE(bad_sd.problem(400).find("uncertainty"), std::string::npos);
  KeyframeEvidence bad_intrinsics = evidence;
  bad_intrinsics.intrinsics.cx = NAN;
  EXPECT_NE(bad_intrinsics.problem(400).find("intrinsics"), std::string::npos);

  // A thumbnail is WebP of at most 160x120, judged from its header: a PNG, a large WebP and a
  // WebP whose header was cut are refused without decoding them.
  std::vector<uint8_t> png;
  cv::imencode(".png", cv::Mat(2000, 2000, CV_8U, cv::Scalar(0)), png);
  EXPECT_EQ(thumbnailProblem(png), "a thumbnail that is not WebP");
  std::vector<uint8_t> large;
  cv::imencode(".webp", cv::Mat(240, 320, CV_8U, cv::Scalar(0)), large);
  EXPECT_EQ(thumbnailProblem(large), "a thumbnail of 320x240 (at most 160x120)");
  std::vector<uint8_t> lossless;
  cv::imencode(".webp", cv::Mat(121, 100, CV_8U, cv::Scalar(0)), lossless,
               {cv::IMWRITE_WEBP_QUALITY, 101});
  EXPECT_EQ(thumbnailProblem(lossless), "a thumbnail of 100x121 (at most 160x120)");
  std::vector<uint8_t> cut(evidence.thumbnail.begin(), evidence.thumbnail.begin() + 20);
  EXPECT_EQ(thumbnailProblem(cut), "a thumbnail that is not WebP");
  EXPECT_EQ(thumbnailProblem(std::vector<uint8_t>(kMaxThumbnailBytes + 1, 0)),
            "a thumbnail of 65537 bytes (at most 65536)");
  EXPECT_EQ(thumbnailProblem({}), "");

  // The answer's sizes are bounded before it is converted.
  FleetEvidence::Response response;
  toEvidenceResponse(evidence, &response);
  EXPECT_EQ(evidenceResponseProblem(response, 400), "");
  response.keypoints.resize(2 * 1000000);
  EXPECT_NE(evidenceResponseProblem(response, 400).find("1000000 keypoints"), std::string::npos);
  toEvidenceResponse(evidence, &response);
  response.thumbnail.resize(1 << 20);
  EXPECT_NE(evidenceResponseProblem(response, 400).find("a thumbnail of 1048576 bytes"),
            std::string::npos);
  toEvidenceResponse(evidence, &response);
  response.problem.assign(1 << 20, 'p');
  EXPECT_NE(evidenceResponseProblem(response, 400).find("problem text"), std::string::npos);
}
