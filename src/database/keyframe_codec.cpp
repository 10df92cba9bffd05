#include "database/keyframe_codec.h"

#include "landmark_loop_closure/database/database_file.h"

#include <cstdio>
#include <cstdlib>
#include <memory>

namespace landmark_loop_closure {
namespace database_payload {

namespace {

static_assert(sizeof(cv::Point2f) == 2 * sizeof(float) &&
                  sizeof(cv::Point3f) == 3 * sizeof(float) &&
                  sizeof(cv::Rect2f) == 4 * sizeof(float),
              "points and boxes are stored as their floats");

void writePose(PayloadWriter* out, const Pose& pose) {
  for (int i = 0; i < 3; ++i) out->f64(pose.position[i]);
  out->f64(pose.orientation.w());
  out->f64(pose.orientation.x());
  out->f64(pose.orientation.y());
  out->f64(pose.orientation.z());
}

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

void writeKeyframe(PayloadWriter* out, const KeyframeRecord& keyframe) {
  out->u64(keyframe.id);
  out->u32(keyframe.session);
  out->f64(keyframe.stamp);
  writePose(out, keyframe.pose);
  out->f64(keyframe.path.metres);
  out->f64(keyframe.path.radians);

  // Points and boxes are plain floats side by side (static_asserts below).
  const ImageDescriptor& descriptor = keyframe.descriptor;
  out->count(descriptor.global.size());
  out->floats(descriptor.global.data(), descriptor.global.size());
  out->count(descriptor.landmark_boxes.size());
  out->floats(reinterpret_cast<const float*>(descriptor.landmark_boxes.data()),
              4 * descriptor.landmark_boxes.size());
  out->mat(descriptor.landmark_features);

  const LocalFeatures& local = keyframe.local_features;
  out->count(local.points.size());
  out->floats(reinterpret_cast<const float*>(local.points.data()), 2 * local.points.size());
  out->mat(local.descriptors);
  out->i32(local.image_size.width);
  out->i32(local.image_size.height);
  out->count(local.points3d.size());
  out->floats(reinterpret_cast<const float*>(local.points3d.data()), 3 * local.points3d.size());
  out->count(local.depth_sd.size());
  out->floats(local.depth_sd.data(), local.depth_sd.size());

  out->count(keyframe.thumbnail_jpeg.size());
  out->bytes(keyframe.thumbnail_jpeg.data(), keyframe.thumbnail_jpeg.size());
}

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

std::vector<uint8_t> encodeKeyframe(const KeyframeRecord& keyframe) {
  char* buffer = nullptr;
  size_t size = 0;
  std::FILE* memory = open_memstream(&buffer, &size);
  if (memory == nullptr) throw FormatError("out of memory");
  std::unique_ptr<char, decltype(&std::free)> owned(nullptr, &std::free);
  try {
    PayloadWriter writer(memory);
    writeKeyframe(&writer, keyframe);
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

KeyframeRecord decodeKeyframe(const uint8_t* data, size_t size) {
  PayloadReader reader(data, size);
  KeyframeRecord keyframe = readKeyframe(&reader, kDatabaseFileVersion);
  if (reader.remaining() != 0) throw FormatError("bytes left after the keyframe");
  return keyframe;
}

}  // namespace database_payload
}  // namespace landmark_loop_closure
