// The messages robots exchange (FleetKeyframe.msg, FleetEvidence.srv) and their conversions.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "../../src/messages/ros_conversions.h"
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
  evidence.thumbnail = {1, 2, 3};
  FleetEvidence::Response response;
  toEvidenceResponse(evidence, &response);
  FleetEvidence::Request request;
  request.map_id = 77;
  request.id = 12;
  const KeyframeEvidence received = evidenceFromResponse(request, response);
  EXPECT_EQ(received.problem(), "");
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
  EXPECT_EQ(received.wireBytes(), evidence.wireBytes());

  response.descriptors.resize(40);  // Not 32 bytes a keypoint.
  EXPECT_NE(evidenceFromResponse(request, response).problem().find("32-byte descriptor"),
            std::string::npos);
  toEvidenceResponse(evidence, &response);
  response.points3d.resize(3);  // One depth for two keypoints.
  EXPECT_NE(evidenceFromResponse(request, response).problem().find("keypoint depths"),
            std::string::npos);
}
