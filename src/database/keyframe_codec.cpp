#include "database/keyframe_codec.h"

#include "database/old_map_file.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
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
    keyframe.thumbnail = encodeThumbnail(in->mat());  // Version 1 kept raw pixels.
  } else {
    keyframe.thumbnail.resize(in->count(1));
    in->bytes(keyframe.thumbnail.data(), keyframe.thumbnail.size());
  }
  return keyframe;
}

namespace {

// Layout 2 kept landmark features, 3D points and depth deviations in float16 for every keypoint;
// layout 3 keeps landmark boxes in 1/16 pixel and their features in 8 bits with one scale per
// landmark, and depths only for
// the keypoints that have one, as the depth along the keypoint's ray where the points allow,
// with an 8-bit deviation.
constexpr uint32_t kFloat16RecordLayout = 2;
constexpr uint32_t kRecordLayout = 3;
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

float roundedToHalf(float value) { return static_cast<float>(cv::float16_t(value)); }

// Depth deviations in 8 bits: 1/16 of an octave per step (within 2.2 %) from 0.24 mm to 14.7 m,
// clamped there; 255 stands for NaN.
constexpr int kDeviationStepsPerOctave = 16;
constexpr int kDeviationSmallestOctave = -12;
constexpr uint8_t kNoDeviation = 255;

uint8_t deviationCode(float sd) {
  if (std::isnan(sd)) return kNoDeviation;
  if (!(sd > 0.0f)) return 0;
  const double steps =
      std::round((std::log2(sd) - kDeviationSmallestOctave) * kDeviationStepsPerOctave);
  return static_cast<uint8_t>(std::clamp(steps, 0.0, 254.0));
}

float deviationValue(uint8_t code) {
  if (code == kNoDeviation) return std::numeric_limits<float>::quiet_NaN();
  return static_cast<float>(
      std::exp2(static_cast<double>(code) / kDeviationStepsPerOctave + kDeviationSmallestOctave));
}

bool finitePoint(const cv::Point3f& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

// `rows` x `cols` pixel coordinates in 1/16 pixel (u16) when they all fit, else float32.
cv::Mat compactPixels(const float* values, int rows, int cols) {
  cv::Mat compact(rows, cols, CV_32F);
  bool fixed_point = true;
  for (int i = 0; i < rows * cols; ++i) {
    compact.at<float>(i / cols, i % cols) = values[i];
    fixed_point = fixed_point && values[i] >= 0.0f && values[i] <= kLargestPixel;
  }
  if (fixed_point && !compact.empty()) compact.convertTo(compact, CV_16U, kPixelSteps);
  return compact;
}

cv::Mat compactPoints(const std::vector<cv::Point2f>& points) {
  return compactPixels(reinterpret_cast<const float*>(points.data()),
                       static_cast<int>(points.size()), 2);
}

// Pixel coordinates as compactPixels wrote them, as float32.
cv::Mat expandedPixels(const cv::Mat& compact) {
  cv::Mat values;
  compact.convertTo(values, CV_32F, compact.depth() == CV_16U ? 1.0 / kPixelSteps : 1.0);
  return values;
}

void writeLandmarkFeatures(PayloadWriter* out, const cv::Mat& features) {
  out->i32(features.type());  // Restored on reading.
  out->i32(features.rows);
  out->i32(features.cols);
  if (features.empty()) return;
  cv::Mat values;
  features.convertTo(values, CV_32F);
  std::vector<uint8_t> row(sizeof(float) + static_cast<size_t>(values.cols));
  for (int r = 0; r < values.rows; ++r) {
    QuantizedVectors::encode(values.ptr<float>(r), values.cols, row.data());
    out->bytes(row.data(), row.size());
  }
}

cv::Mat readLandmarkFeatures(PayloadReader* in) {
  const int type = in->i32();
  const int rows = in->i32();
  const int cols = in->i32();
  if (rows < 0 || cols < 0) throw FormatError("landmark features of a negative size");
  if (rows == 0 || cols == 0) return cv::Mat();
  if (type != CV_32F && type != CV_16F) throw FormatError("landmark features of an unknown type");
  const uint64_t row_bytes = sizeof(float) + static_cast<uint64_t>(cols);
  if (row_bytes * static_cast<uint64_t>(rows) > in->remaining()) {
    throw FormatError("landmark features larger than the record");
  }
  cv::Mat values(rows, cols, CV_32F);
  std::vector<uint8_t> row(static_cast<size_t>(row_bytes));
  for (int r = 0; r < rows; ++r) {
    in->bytes(row.data(), row.size());
    const std::vector<float> decoded = QuantizedVectors::decode(row.data(), cols);
    std::copy(decoded.begin(), decoded.end(), values.ptr<float>(r));
  }
  cv::Mat features;
  values.convertTo(features, type);
  return features;
}

cv::Mat readFloat16LandmarkFeatures(PayloadReader* in) {
  const int type = in->i32();
  cv::Mat features = in->mat();
  if (!features.empty()) {
    if (type != CV_32F && type != CV_16F) {
      throw FormatError("landmark features of an unknown type");
    }
    features.convertTo(features, type);
  }
  return features;
}

// x/z = slope_x * u + offset_x and y/z = slope_y * v + offset_y: every point of a keyframe lies
// on its keypoint's ray through a pinhole camera, so its depth gives the point back.
struct RayModel {
  float slope_x = 0.0f, offset_x = 0.0f, slope_y = 0.0f, offset_y = 0.0f;
  cv::Point3f point(const cv::Point2f& pixel, float z) const {
    return {z * (slope_x * pixel.x + offset_x), z * (slope_y * pixel.y + offset_y), z};
  }
};

// Least-squares line through (pixel, ratio) pairs; false when the pixels do not spread.
bool fitLine(const std::vector<double>& pixel, const std::vector<double>& ratio, float* slope,
             float* offset) {
  const double n = static_cast<double>(pixel.size());
  double sum_p = 0.0, sum_r = 0.0, sum_pp = 0.0, sum_pr = 0.0;
  for (size_t i = 0; i < pixel.size(); ++i) {
    sum_p += pixel[i];
    sum_r += ratio[i];
    sum_pp += pixel[i] * pixel[i];
    sum_pr += pixel[i] * ratio[i];
  }
  const double spread = n * sum_pp - sum_p * sum_p;
  if (n < 2.0 || !(spread > 1e-6 * n * n)) return false;
  const double a = (n * sum_pr - sum_p * sum_r) / spread;
  *slope = static_cast<float>(a);
  *offset = static_cast<float>((sum_r - a * sum_p) / n);
  return std::isfinite(*slope) && std::isfinite(*offset);
}

// The ray model of `points` seen at `pixels`, when it gives every point back as closely as
// float16 coordinates would (1 mm per metre of distance).
bool fitRayModel(const std::vector<cv::Point2f>& pixels, const std::vector<cv::Point3f>& points,
                 RayModel* model) {
  std::vector<double> u, v, x_ratio, y_ratio;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!(points[i].z > 0.0f)) return false;
    u.push_back(pixels[i].x);
    v.push_back(pixels[i].y);
    x_ratio.push_back(static_cast<double>(points[i].x) / points[i].z);
    y_ratio.push_back(static_cast<double>(points[i].y) / points[i].z);
  }
  if (!fitLine(u, x_ratio, &model->slope_x, &model->offset_x) ||
      !fitLine(v, y_ratio, &model->slope_y, &model->offset_y)) {
    return false;
  }
  for (size_t i = 0; i < points.size(); ++i) {
    const cv::Point3f back = model->point(pixels[i], roundedToHalf(points[i].z));
    if (cv::norm(back - points[i]) > 1e-3 * cv::norm(points[i])) return false;
  }
  return true;
}

std::vector<cv::Point2f> decodedPoints(const cv::Mat& compact) {
  const cv::Mat values = expandedPixels(compact);
  std::vector<cv::Point2f> points(static_cast<size_t>(values.rows));
  for (int i = 0; i < values.rows; ++i) {
    points[static_cast<size_t>(i)] = {values.at<float>(i, 0), values.at<float>(i, 1)};
  }
  return points;
}

// Depths: whether 3D points are kept at all; then a bit per keypoint (has a point); the ray
// model and each point's depth, or its float16 coordinates; each point's depth deviation in 8
// bits. A
// keypoint without a point reads back NaN, as the geometry code leaves it.
void writeDepths(PayloadWriter* out, const LocalFeatures& local, const cv::Mat& compact_points) {
  const size_t n = local.points.size();
  const bool kept = n > 0 && local.points3d.size() == n && local.depth_sd.size() == n;
  out->u32(kept ? 1 : 0);
  if (!kept) return;
  const std::vector<cv::Point2f> pixels = decodedPoints(compact_points);
  cv::Mat mask(1, static_cast<int>((n + 7) / 8), CV_8U, cv::Scalar(0));
  std::vector<cv::Point2f> with_pixels;
  std::vector<cv::Point3f> with_points;
  std::vector<float> with_sd;
  for (size_t i = 0; i < n; ++i) {
    if (!finitePoint(local.points3d[i])) continue;
    mask.at<uint8_t>(0, static_cast<int>(i / 8)) |= static_cast<uint8_t>(1u << (i % 8));
    with_pixels.push_back(pixels[i]);
    with_points.push_back(local.points3d[i]);
    with_sd.push_back(local.depth_sd[i]);
  }
  out->mat(mask);
  RayModel model;
  const bool on_rays = fitRayModel(with_pixels, with_points, &model);
  out->u32(on_rays ? 1 : 0);
  if (on_rays) {
    out->floats(&model.slope_x, 4);
    std::vector<float> depths;
    for (const cv::Point3f& point : with_points) depths.push_back(point.z);
    out->mat(toHalf(cv::Mat(depths, false)));
  } else {
    out->mat(toHalf(cv::Mat(with_points, false).reshape(1)));
  }
  cv::Mat deviations(static_cast<int>(with_sd.size()), 1, CV_8U);
  for (size_t j = 0; j < with_sd.size(); ++j) {
    deviations.at<uint8_t>(static_cast<int>(j), 0) = deviationCode(with_sd[j]);
  }
  out->mat(deviations);
}

void readDepths(PayloadReader* in, LocalFeatures* local) {
  local->points3d.clear();
  local->depth_sd.clear();
  if (in->u32() == 0) return;
  const size_t n = local->points.size();
  const cv::Mat mask = in->mat();
  if (mask.type() != CV_8U || mask.total() != (n + 7) / 8) {
    throw FormatError("the depth mask does not match the keypoints");
  }
  std::vector<size_t> with;
  for (size_t i = 0; i < n; ++i) {
    if (mask.data[i / 8] & (1u << (i % 8))) with.push_back(i);
  }
  const int count = static_cast<int>(with.size());
  const bool on_rays = in->u32() != 0;
  RayModel model;
  if (on_rays) in->floats(&model.slope_x, 4);
  cv::Mat values = in->mat();
  cv::Mat sd = in->mat();
  if (values.rows != count || sd.rows != count ||
      (count > 0 && (values.cols != (on_rays ? 1 : 3) || sd.cols != 1))) {
    throw FormatError("depths disagree with the keypoints that have one");
  }
  if (count > 0 && sd.type() != CV_8U) throw FormatError("depth deviations of another type");
  values.convertTo(values, CV_32F);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  local->points3d.assign(n, cv::Point3f(nan, nan, nan));
  local->depth_sd.assign(n, nan);
  for (int j = 0; j < count; ++j) {
    const size_t i = with[static_cast<size_t>(j)];
    local->points3d[i] = on_rays ? model.point(local->points[i], values.at<float>(j, 0))
                                 : cv::Point3f(values.at<float>(j, 0), values.at<float>(j, 1),
                                               values.at<float>(j, 2));
    local->depth_sd[i] = deviationValue(sd.at<uint8_t>(j, 0));
  }
}

void readFloat16Depths(PayloadReader* in, LocalFeatures* local) {
  cv::Mat points3d = in->mat();
  cv::Mat depth_sd = in->mat();
  if ((!points3d.empty() && points3d.cols != 3) || (!depth_sd.empty() && depth_sd.cols != 1) ||
      (!points3d.empty() && points3d.rows != static_cast<int>(local->points.size())) ||
      depth_sd.rows != points3d.rows) {
    throw FormatError("keypoints and depths disagree");
  }
  local->points3d.clear();
  local->depth_sd.clear();
  if (points3d.empty()) return;
  points3d.convertTo(points3d, CV_32F);
  for (int i = 0; i < points3d.rows; ++i) {
    local->points3d.emplace_back(points3d.at<float>(i, 0), points3d.at<float>(i, 1),
                                 points3d.at<float>(i, 2));
  }
  depth_sd.convertTo(depth_sd, CV_32F);
  local->depth_sd.assign(depth_sd.begin<float>(), depth_sd.end<float>());
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
    out->mat(compactPixels(reinterpret_cast<const float*>(descriptor.landmark_boxes.data()),
                           static_cast<int>(descriptor.landmark_boxes.size()), 4));
    writeLandmarkFeatures(out, descriptor.landmark_features);

    const LocalFeatures& local = keyframe.local_features;
    const cv::Mat points = compactPoints(local.points);
    out->mat(points);
    out->mat(local.descriptors);
    out->i32(local.image_size.width);
    out->i32(local.image_size.height);
    writeDepths(out, local, points);

    out->count(keyframe.thumbnail.size());
    out->bytes(keyframe.thumbnail.data(), keyframe.thumbnail.size());
  });
}

void decodeRecord(const uint8_t* data, size_t size, KeyframeRecord* keyframe) {
  PayloadReader in(data, size);
  const uint32_t layout = in.u32();
  if (layout != kRecordLayout && layout != kFloat16RecordLayout) {
    throw FormatError("record layout " + std::to_string(layout) + " is not known");
  }
  ImageDescriptor& descriptor = keyframe->descriptor;
  if (layout == kRecordLayout) {
    const cv::Mat boxes = expandedPixels(in.mat());
    if (!boxes.empty() && boxes.cols != 4) throw FormatError("landmark boxes of another shape");
    descriptor.landmark_boxes.resize(static_cast<size_t>(boxes.rows));
    // An image without landmarks has no boxes, and memcpy takes no null pointer even for 0 bytes.
    if (!boxes.empty()) {
      std::memcpy(descriptor.landmark_boxes.data(), boxes.data, boxes.total() * sizeof(float));
    }
    descriptor.landmark_features = readLandmarkFeatures(&in);
  } else {
    descriptor.landmark_boxes.resize(in.count(16));
    in.floats(reinterpret_cast<float*>(descriptor.landmark_boxes.data()),
              4 * descriptor.landmark_boxes.size());
    descriptor.landmark_features = readFloat16LandmarkFeatures(&in);
  }
  if (descriptor.landmark_features.rows != static_cast<int>(descriptor.landmark_boxes.size())) {
    throw FormatError("landmark boxes and features disagree");
  }

  LocalFeatures& local = keyframe->local_features;
  cv::Mat points = in.mat();
  local.descriptors = in.mat();
  local.image_size.width = in.i32();
  local.image_size.height = in.i32();
  if ((!points.empty() && points.cols != 2) || local.descriptors.rows != points.rows) {
    throw FormatError("keypoints and descriptors disagree");
  }
  local.points = decodedPoints(points);
  if (layout == kRecordLayout) {
    readDepths(&in, &local);
  } else {
    readFloat16Depths(&in, &local);
  }
  keyframe->thumbnail.resize(in.count(1));
  in.bytes(keyframe->thumbnail.data(), keyframe->thumbnail.size());
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
