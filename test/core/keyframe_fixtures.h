#pragma once

// Keyframes with every field set, a field-by-field comparison, and a fresh folder per test for the
// map file and store tests.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

namespace landmark_loop_closure {

/// The same keyframe for the same id: its random parts are seeded by it.
/// The global dimension and descriptor identity of the test maps.
constexpr int kDimension = 6;
inline const std::string kIdentity = "type=test dimension=6";

inline KeyframeRecord makeKeyframe(uint64_t id, uint32_t session, int dimension = kDimension) {
  cv::RNG random(id * 7919 + 1);
  KeyframeRecord keyframe;
  keyframe.id = id;
  keyframe.session = session;
  keyframe.stamp = 1700000000.25 + static_cast<double>(id);
  keyframe.pose.position = Eigen::Vector3d(1.5 * id, -2.0, 0.125);
  keyframe.pose.orientation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * id, Eigen::Vector3d::UnitZ()));
  keyframe.path = {0.3 * id, 0.01 * id};
  for (int i = 0; i < dimension; ++i) keyframe.descriptor.global.push_back(0.1f * i + id);
  keyframe.descriptor.landmark_boxes = {{1.0f, 2.0f, 30.5f, 40.25f}, {5.0f, 6.0f, 7.0f, 8.0f}};
  cv::Mat features(2, 4, CV_32F);
  random.fill(features, cv::RNG::UNIFORM, -1.0, 1.0);
  features.convertTo(keyframe.descriptor.landmark_features, CV_16F);
  LocalFeatures& local = keyframe.local_features;
  local.points = {{10.5f, 20.25f}, {300.0f, 200.0f}, {0.0f, 0.0f}};
  local.descriptors = cv::Mat(3, 32, CV_8U);
  random.fill(local.descriptors, cv::RNG::UNIFORM, 0, 256);
  local.image_size = cv::Size(320, 240);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  local.points3d = {{0.1f, 0.2f, 3.0f}, {nan, nan, nan}, {-1.0f, 0.5f, 12.0f}};
  local.depth_sd = {0.02f, nan, 0.4f};
  keyframe.thumbnail =
      encodeThumbnail(cv::Mat(12, 16, CV_8U, cv::Scalar(static_cast<double>(id % 200))));
  return keyframe;
}

/// `values` through 8 bits with one scale (QuantizedVectors), as the map store keeps them.
inline std::vector<float> in8Bits(const std::vector<float>& values) {
  return QuantizedVectors::decode(QuantizedVectors::encode(values).data(),
                                  static_cast<int>(values.size()));
}

/// `keyframe` as the map store gives it back: the global vector and each landmark's features in
/// 8 bits (expectSame allows 3D points their float16 error and depth deviations their 8-bit
/// one; keypoints are kept exactly at these positions).
inline KeyframeRecord asStored(KeyframeRecord keyframe) {
  keyframe.descriptor.global = in8Bits(keyframe.descriptor.global);
  cv::Mat& features = keyframe.descriptor.landmark_features;
  if (!features.empty()) {
    cv::Mat values;
    features.convertTo(values, CV_32F);
    for (int r = 0; r < values.rows; ++r) {
      const std::vector<float> row = in8Bits(values.row(r).clone().reshape(1, 1));
      std::copy(row.begin(), row.end(), values.ptr<float>(r));
    }
    values.convertTo(features, features.type());
  }
  return keyframe;
}

inline bool sameMat(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  if (a.empty()) return true;
  const size_t row_bytes = static_cast<size_t>(a.cols) * a.elemSize();
  for (int r = 0; r < a.rows; ++r) {
    if (std::memcmp(a.ptr(r), b.ptr(r), row_bytes) != 0) return false;
  }
  return true;
}

inline bool sameFloat(float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

inline void expectSame(const KeyframeRecord& a, const KeyframeRecord& b) {
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(a.session, b.session);
  EXPECT_EQ(a.stamp, b.stamp);
  EXPECT_EQ(a.pose.position, b.pose.position);
  EXPECT_EQ(a.pose.orientation.coeffs(), b.pose.orientation.coeffs());
  EXPECT_EQ(a.path.metres, b.path.metres);
  EXPECT_EQ(a.path.radians, b.path.radians);
  EXPECT_EQ(a.descriptor.global, b.descriptor.global);
  EXPECT_EQ(a.descriptor.landmark_boxes, b.descriptor.landmark_boxes);
  EXPECT_TRUE(sameMat(a.descriptor.landmark_features, b.descriptor.landmark_features));
  EXPECT_EQ(a.local_features.points, b.local_features.points);
  EXPECT_TRUE(sameMat(a.local_features.descriptors, b.local_features.descriptors));
  EXPECT_EQ(a.local_features.image_size, b.local_features.image_size);
  ASSERT_EQ(a.local_features.points3d.size(), b.local_features.points3d.size());
  for (size_t i = 0; i < a.local_features.points3d.size(); ++i) {
    const cv::Point3f& p = a.local_features.points3d[i];
    const cv::Point3f& q = b.local_features.points3d[i];
    const bool both_absent = std::isnan(p.x) && std::isnan(q.x);
    EXPECT_TRUE(both_absent || cv::norm(p - q) <= 1e-3 * cv::norm(p))
        << i << ": " << p << " against " << q;
    const float sd = a.local_features.depth_sd[i];
    const float other = b.local_features.depth_sd[i];
    EXPECT_TRUE(sameFloat(sd, other) || std::abs(other - sd) <= 0.022f * sd)
        << i << ": deviation " << sd << " against " << other;
  }
  EXPECT_EQ(a.thumbnail, b.thumbnail);
}

/// Why KeyframeStore::open refuses `path` ("" when it opens).
inline std::string openRefusal(const std::string& path, const std::string& identity = kIdentity,
                               int dimension = kDimension) {
  try {
    KeyframeStore::open(path, identity, dimension);
  } catch (const std::runtime_error& error) {
    return error.what();
  }
  return "";
}

/// A folder of its own for each test (named after it, removed after it) with a map path in it.
class MapFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
    folder_ =
        std::filesystem::temp_directory_path() / (std::string(test->test_suite_name()) + "_" +
                                                  std::to_string(::getpid()) + "_" + test->name());
    std::filesystem::remove_all(folder_);
    std::filesystem::create_directories(folder_);
    path_ = (folder_ / "map.db").string();
  }
  void TearDown() override { std::filesystem::remove_all(folder_); }

  std::filesystem::path folder_;
  std::string path_;
};

}  // namespace landmark_loop_closure
