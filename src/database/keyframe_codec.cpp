#include "database/keyframe_codec.h"

#include "database/old_map_file.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>

namespace landmark_loop_closure {
namespace database_payload {

namespace {

static_assert(sizeof(cv::Point2f) == 2 * sizeof(float) &&
                  sizeof(cv::Point3f) == 3 * sizeof(float) &&
                  sizeof(cv::Rect2f) == 4 * sizeof(float),
              "points and boxes are stored as their floats");

Pose readPose(PayloadReader* in) {
  Pose pose;
  for (int i = 0; i < 3; ++i) pose.position[i] = in->f64();
  const double w = in->f64();
  const double x = in->f64();
  const double y = in->f64();
  const double z = in->f64();
  pose.orientation = Eigen::Quaterniond(w, x, y, z);
  return pose;
}

}  // namespace

KeyframeRecord readKeyframe(PayloadReader* in, uint32_t version) {
  KeyframeRecord keyframe;
  keyframe.id = in->u64();
  keyframe.session = in->u32();
  keyframe.stamp = in->f64();
  keyframe.pose = readPose(in);
  keyframe.path.metres = in->f64();
  keyframe.path.radians = in->f64();

  ImageDescriptor& descriptor = keyframe.descriptor;
  descriptor.global.resize(in->count(4));
  in->floats(descriptor.global.data(), descriptor.global.size());
  descriptor.landmark_boxes.resize(in->count(16));
  in->floats(reinterpret_cast<float*>(descriptor.landmark_boxes.data()),
             4 * descriptor.landmark_boxes.size());
  descriptor.landmark_features = in->mat();
  if (descriptor.landmark_features.rows != static_cast<int>(descriptor.landmark_boxes.size())) {
    throw FormatError("keyframe " + std::to_string(keyframe.id) +
                      ": landmark boxes and features disagree");
  }

  LocalFeatures& local = keyframe.local_features;
  local.points.resize(in->count(8));
  in->floats(reinterpret_cast<float*>(local.points.data()), 2 * local.points.size());
  local.descriptors = in->mat();
  local.image_size.width = in->i32();
  local.image_size.height = in->i32();
  local.points3d.resize(in->count(12));
  in->floats(reinterpret_cast<float*>(local.points3d.data()), 3 * local.points3d.size());
  local.depth_sd.resize(in->count(4));
  in->floats(local.depth_sd.data(), local.depth_sd.size());
  const size_t points = local.points.size();
  if (local.descriptors.rows != static_cast<int>(points) ||
      (!local.points3d.empty() && local.points3d.size() != points) ||
      local.depth_sd.size() != local.points3d.size()) {
    throw FormatError("keyframe " + std::to_string(keyframe.id) +
                      ": keypoints, descriptors and depths disagree");
  }

  if (version == 1) {
    keyframe.thumbnail_jpeg = encodeThumbnail(in->mat());  // Version 1 kept raw pixels.
  } else {
    keyframe.thumbnail_jpeg.resize(in->count(1));
    in->bytes(keyframe.thumbnail_jpeg.data(), keyframe.thumbnail_jpeg.size());
  }
  return keyframe;
}

namespace {

constexpr uint32_t kRecordLayout = 2;
constexpr float kPixelSteps = 16.0f;  // Keypoints in 1/16 pixel.
constexpr float kLargestPixel = 65535.0f / kPixelSteps;

template <typename Write>
std::vector<uint8_t> writeToMemory(const Write& write) {
  char* buffer = nullptr;
  size_t size = 0;
  std::FILE* memory = open_memstream(&buffer, &size);
  if (memory == nullptr) throw FormatError("out of memory");
  std::unique_ptr<char, decltype(&std::free)> owned(nullptr, &std::free);
  try {
    PayloadWriter writer(memory);
    write(&writer);
    writer.flush();
  } catch (...) {
    std::fclose(memory);
    owned.reset(buffer);
    throw;
  }
  std::fclose(memory);  // Sets buffer and size.
  owned.reset(buffer);
  const auto* bytes = reinterpret_cast<const uint8_t*>(buffer);
  return std::vector<uint8_t>(bytes, bytes + size);
}

cv::Mat toHalf(const cv::Mat& values) {
  if (values.empty() || values.depth() != CV_32F) return values;
  cv::Mat half;
  values.convertTo(half, CV_16F);
  return half;
}

}  // namespace

KeyframeRecord decodeKeyframe(const uint8_t* data, size_t size) {
  PayloadReader reader(data, size);
  KeyframeRecord keyframe = readKeyframe(&reader, kOldMapFileVersion);
  if (reader.remaining() != 0) throw FormatError("bytes left after the keyframe");
  return keyframe;
}

std::vector<uint8_t> encodeRecord(const KeyframeRecord& keyframe) {
  return writeToMemory([&](PayloadWriter* out) {
    out->u32(kRecordLayout);
    const ImageDescriptor& descriptor = keyframe.descriptor;
    out->count(descriptor.landmark_boxes.size());
    out->floats(reinterpret_cast<const float*>(descriptor.landmark_boxes.data()),
                4 * descriptor.landmark_boxes.size());
    out->i32(descriptor.landmark_features.type());  // Restored on reading.
    out->mat(toHalf(descriptor.landmark_features));

    const LocalFeatures& local = keyframe.local_features;
    const bool fixed_point = std::all_of(local.points.begin(), local.points.end(), [](auto p) {
      return p.x >= 0.0f && p.y >= 0.0f && p.x <= kLargestPixel && p.y <= kLargestPixel;
    });
    cv::Mat points(static_cast<int>(local.points.size()), 2, CV_32F);
    for (size_t i = 0; i < local.points.size(); ++i) {
      points.at<float>(static_cast<int>(i), 0) = local.points[i].x;
      points.at<float>(static_cast<int>(i), 1) = local.points[i].y;
    }
    if (fixed_point && !points.empty()) points.convertTo(points, CV_16U, kPixelSteps);
    out->mat(points);
    out->mat(local.descriptors);
    out->i32(local.image_size.width);
    out->i32(local.image_size.height);
    out->mat(toHalf(cv::Mat(local.points3d, false).reshape(1)));
    out->mat(toHalf(cv::Mat(local.depth_sd, false)));

    out->count(keyframe.thumbnail_jpeg.size());
    out->bytes(keyframe.thumbnail_jpeg.data(), keyframe.thumbnail_jpeg.size());
  });
}

void decodeRecord(const uint8_t* data, size_t size, KeyframeRecord* keyframe) {
  PayloadReader in(data, size);
  const uint32_t layout = in.u32();
  if (layout != kRecordLayout) {
    throw FormatError("record layout " + std::to_string(layout) + " is not known");
  }
  ImageDescriptor& descriptor = keyframe->descriptor;
  descriptor.landmark_boxes.resize(in.count(16));
  in.floats(reinterpret_cast<float*>(descriptor.landmark_boxes.data()),
            4 * descriptor.landmark_boxes.size());
  const int feature_type = in.i32();
  descriptor.landmark_features = in.mat();
  if (!descriptor.landmark_features.empty()) {
    if (feature_type != CV_32F && feature_type != CV_16F) {
      throw FormatError("landmark features of an unknown type");
    }
    descriptor.landmark_features.convertTo(descriptor.landmark_features, feature_type);
  }
  if (descriptor.landmark_features.rows != static_cast<int>(descriptor.landmark_boxes.size())) {
    throw FormatError("landmark boxes and features disagree");
  }

  LocalFeatures& local = keyframe->local_features;
  cv::Mat points = in.mat();
  local.descriptors = in.mat();
  local.image_size.width = in.i32();
  local.image_size.height = in.i32();
  cv::Mat points3d = in.mat();
  cv::Mat depth_sd = in.mat();
  if ((!points.empty() && points.cols != 2) || (!points3d.empty() && points3d.cols != 3) ||
      (!depth_sd.empty() && depth_sd.cols != 1) || local.descriptors.rows != points.rows ||
      (!points3d.empty() && points3d.rows != points.rows) || depth_sd.rows != points3d.rows) {
    throw FormatError("keypoints, descriptors and depths disagree");
  }
  if (!points.empty()) {
    points.convertTo(points, CV_32F, points.depth() == CV_16U ? 1.0 / kPixelSteps : 1.0);
    local.points.resize(static_cast<size_t>(points.rows));
    for (int i = 0; i < points.rows; ++i) {
      local.points[static_cast<size_t>(i)] = {points.at<float>(i, 0), points.at<float>(i, 1)};
    }
  }
  if (!points3d.empty()) {
    points3d.convertTo(points3d, CV_32F);
    local.points3d.resize(static_cast<size_t>(points3d.rows));
    for (int i = 0; i < points3d.rows; ++i) {
      local.points3d[static_cast<size_t>(i)] = {points3d.at<float>(i, 0), points3d.at<float>(i, 1),
                                                points3d.at<float>(i, 2)};
    }
    depth_sd.convertTo(depth_sd, CV_32F);
    local.depth_sd.assign(depth_sd.begin<float>(), depth_sd.end<float>());
  }
  keyframe->thumbnail_jpeg.resize(in.count(1));
  in.bytes(keyframe->thumbnail_jpeg.data(), keyframe->thumbnail_jpeg.size());
  if (in.remaining() != 0) throw FormatError("bytes left after the record");
}

std::vector<uint8_t> encodeMotion(const KeyframeSummary& summary) {
  const double values[9] = {
      summary.pose.position.x(),    summary.pose.position.y(),    summary.pose.position.z(),
      summary.pose.orientation.w(), summary.pose.orientation.x(), summary.pose.orientation.y(),
      summary.pose.orientation.z(), summary.path.metres,          summary.path.radians};
  std::vector<uint8_t> bytes(sizeof(values));
  for (size_t i = 0; i < 9; ++i) {
    uint64_t bits = 0;
    std::memcpy(&bits, &values[i], sizeof(bits));
    encode(bits, bytes.data() + 8 * i);
  }
  return bytes;
}

void decodeMotion(const uint8_t* data, size_t size, KeyframeSummary* summary) {
  if (size != 9 * sizeof(double))
    throw FormatError("a keyframe's pose has " + std::to_string(size) + " bytes, not 72");
  double values[9];
  for (size_t i = 0; i < 9; ++i) {
    const uint64_t bits = decode<uint64_t>(data + 8 * i);
    std::memcpy(&values[i], &bits, sizeof(bits));
  }
  summary->pose.position = Eigen::Vector3d(values[0], values[1], values[2]);
  summary->pose.orientation = Eigen::Quaterniond(values[3], values[4], values[5], values[6]);
  summary->path.metres = values[7];
  summary->path.radians = values[8];
}

}  // namespace database_payload
}  // namespace landmark_loop_closure
