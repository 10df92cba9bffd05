#pragma once

// How fuzz_loop_detector reads its input as what the detector's worker receives: frames admitted
// as the node admits them, then described, searched, verified and stored by addKeyframe with
// images, depth images, poses and intrinsics from the fuzzer; tests replay the kept inputs with it.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "byte_stream.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {
namespace fuzz {

/// A textured picture of place `place` (the same place gives the same picture, so loops happen),
/// `width` x `height`, of OpenCV type `type`, with `overwrites` pixels set from the input.
inline cv::Mat placeImage(ByteStream* in, uint8_t place, int width, int height, int type) {
  cv::RNG rng(0x9e3779b9u + place);
  cv::Mat cells(9, 12, CV_8UC1);
  rng.fill(cells, cv::RNG::UNIFORM, 0, 256);
  cv::Mat grey;
  cv::resize(cells, grey, cv::Size(width, height), 0, 0, cv::INTER_NEAREST);
  const int overwrites = in->byte() % 8;
  for (int k = 0; k < overwrites; ++k) {
    const int x = in->byte() % width, y = in->byte() % height;
    grey.at<uint8_t>(y, x) = in->byte();
  }
  cv::Mat image;
  switch (type) {
    case CV_8UC3:
      cv::cvtColor(grey, image, cv::COLOR_GRAY2BGR);
      break;
    case CV_8UC4:
      cv::cvtColor(grey, image, cv::COLOR_GRAY2BGRA);
      break;
    case CV_16UC1:
      grey.convertTo(image, CV_16U, 257.0);
      break;
    case CV_16UC3: {
      cv::Mat colour;
      cv::cvtColor(grey, colour, cv::COLOR_GRAY2BGR);
      colour.convertTo(image, CV_16U, 257.0);
      break;
    }
    case CV_32FC1:
      grey.convertTo(image, CV_32F, 1.0 / 255.0);
      break;
    default:
      image = grey;
  }
  return image;
}

/// A depth image: none, or 16-bit (mm) or float (m), of the image's size or another, with values
/// from the input (non-finite, negative and zero ones included).
inline cv::Mat depthImage(ByteStream* in, cv::Size image_size) {
  const uint8_t kind = in->byte() % 4;
  if (kind == 0) return cv::Mat();
  const cv::Size size =
      (kind == 3) ? cv::Size(1 + in->byte() % 64, 1 + in->byte() % 48) : image_size;
  const double value = in->number();
  cv::Mat depth;
  if (kind == 1) {
    const double millimetres = std::isfinite(value) ? std::clamp(value * 1000.0, 0.0, 65535.0) : 0;
    depth = cv::Mat(size, CV_16UC1, cv::Scalar(millimetres));
  } else {
    depth = cv::Mat(size, CV_32FC1, cv::Scalar(value));
  }
  const int overwrites = in->byte() % 8;
  for (int k = 0; k < overwrites; ++k) {
    const int x = in->byte() % size.width, y = in->byte() % size.height;
    if (depth.type() == CV_16UC1) {
      depth.at<uint16_t>(y, x) = static_cast<uint16_t>(in->byte() * 64);
    } else {
      depth.at<float>(y, x) = static_cast<float>(in->number());
    }
  }
  return depth;
}

/// Intrinsics of `size`: none, a plausible pinhole (with or without a distortion model), or any
/// numbers and any size.
inline CameraIntrinsics intrinsics(ByteStream* in, cv::Size size) {
  CameraIntrinsics camera;
  const uint8_t kind = in->byte() % 4;
  if (kind == 0) return camera;
  if (kind == 3) {
    camera.fx = in->number();
    camera.fy = in->number();
    camera.cx = in->number();
    camera.cy = in->number();
    camera.image_size = cv::Size(in->byte(), in->byte());
  } else {
    camera.fx = camera.fy = 0.8 * size.width;
    camera.cx = 0.5 * size.width;
    camera.cy = 0.5 * size.height;
    camera.image_size = size;
  }
  const uint8_t model = in->byte() % 4;
  if (model == 1 || model == 2) {
    camera.distortion = model == 1 ? LensDistortion::kPlumbBob : LensDistortion::kEquidistant;
    camera.distortion_name = model == 1 ? "plumb_bob" : "equidistant";
    const int count = in->byte() % 9;  // Too few or too many for the model, too.
    for (int k = 0; k < count; ++k) camera.coefficients.push_back(in->number() / 8.0);
  }
  return camera;
}

/// Byte 0-1 choose the options (verification, the odometry gate, standardisation, sequences, the
/// calibrated decision, triangulation, thumbnails, the descriptor); then operations until the
/// input ends (at most 48): a frame (stamp step, motion along a lap of 12 places or any pose,
/// place, size, image type, intrinsics, depth), a mode switch, an odometry restart or a reset.
/// Every frame goes through admit() and, when it is a keyframe, addKeyframe(), as the worker
/// runs them. False when an invariant breaks: a loop that names an unknown keyframe or its own, a
/// score that is not finite, a database that shrank without a reset.
/// What a replay reached, for tests that check a kept input still drives the detector deep.
struct LoopDetectorReplay {
  int keyframes = 0;  ///< Keyframes addKeyframe took without refusing them.
  int loops = 0;
};

inline bool replayLoopDetectorInput(const uint8_t* data, size_t size,
                                    LoopDetectorReplay* reached = nullptr) {
  LoopDetectorReplay unused;
  if (reached == nullptr) reached = &unused;
  ByteStream in(data, size);
  const uint8_t flags = in.byte();
  const uint8_t more_flags = in.byte();
  LoopDetectorOptions options;
  options.keyframe.min_motion = 0.5;
  options.keyframe.max_motion = 50.0;
  options.database.min_size = 4;
  options.database.exclude_recent_keyframes = 2;
  options.database.exclude_recent_seconds = 0.0;
  options.acceptance.consistent_keyframes = 1 + (flags & 1);
  options.verification.enabled = (flags >> 1) & 1;
  options.verification.min_inliers = 8;
  options.verification.required = (flags >> 2) & 1;
  options.odometry_gate.enabled = (flags >> 3) & 1;
  options.descriptor.condition_window = ((flags >> 4) & 1) ? 3 : 0;
  options.acceptance.sequence.length = ((flags >> 5) & 1) ? 3 : 1;
  options.acceptance.max_false_alarms = ((flags >> 6) & 1) ? 0.003 : 0.0;
  options.metric_pose.triangulate_from_odometry = (flags >> 7) & 1;
  options.keep_thumbnails = more_flags & 1;
  options.appearance.enabled = (more_flags >> 1) & 1;
  options.descriptor.type = ((more_flags >> 2) & 1) ? "hog_whole" : "hog";
  options.acceptance.min_score = 0.3;
  if (!options.validate().empty()) return true;  // A combination the node refuses at start.
  LoopDetector detector(options, makeDescriptorExtractor(options.descriptor));

  double stamp = 100.0;
  int step = 0;
  size_t stored = 0;
  bool odometry_restarted = false;
  for (int operations = 0; operations < 48 && !in.empty(); ++operations) {
    const uint8_t kind = in.byte() % 16;
    if (kind == 13) {
      detector.setMode(detector.mode() == DetectorMode::kMapping ? DetectorMode::kLocalization
                                                                 : DetectorMode::kMapping);
      continue;
    }
    if (kind == 14) {
      odometry_restarted = true;  // Marked on the next keyframe, as the worker marks it.
      continue;
    }
    if (kind == 15) {
      detector.map().reset();
      stored = 0;
      continue;
    }
    // A frame: mostly 1 s and one metre on, sometimes any stamp step and any pose.
    const uint8_t stamp_kind = in.byte();
    stamp += stamp_kind < 200 ? 1.0 : in.number();
    Pose pose;
    const uint8_t place = in.byte() % 12;
    if (kind < 11) {
      ++step;
      const double angle = 2.0 * M_PI * place / 12.0;
      pose = planarPose(20.0 * std::cos(angle), 20.0 * std::sin(angle), angle + M_PI / 2);
    } else {
      pose.position = Eigen::Vector3d(in.number(), in.number(), in.number());
      pose.orientation = quaternion(&in);
    }
    static const int kTypes[] = {CV_8UC1,  CV_8UC3,  CV_8UC4, CV_16UC1,
                                 CV_16UC3, CV_32FC1, CV_8SC1, CV_64FC1};
    const uint8_t shape = in.byte();
    const int width = 8 + 8 * (shape % 12), height = 8 + 8 * ((shape >> 4) % 9);
    const int type = kTypes[in.byte() % 8];
    const cv::Mat image = placeImage(&in, place, width, height, type);
    const CameraIntrinsics camera = intrinsics(&in, image.size());
    const cv::Mat depth = depthImage(&in, image.size());
    const FrameAdmission admission = detector.admit(stamp, pose, width, height, type);
    if (!admission.isKeyframe()) continue;
    if (odometry_restarted) detector.markOdometryRestart(admission.keyframe_id);
    odometry_restarted = false;
    const KeyframeResult result =
        detector.addKeyframe(admission.keyframe_id, stamp, pose, image, camera, depth);
    if (result.error) continue;
    ++reached->keyframes;
    if (result.loop) {
      ++reached->loops;
      const AcceptedLoop& loop = *result.loop;
      if (loop.match_id >= loop.query_id || !detector.database().findSummary(loop.match_id)) {
        return false;
      }
      if (!std::isfinite(loop.score) || !std::isfinite(loop.global_score)) return false;
      if (loop.relative_pose && (!loop.relative_pose->rotation.allFinite() ||
                                 !loop.relative_pose->translation.allFinite() ||
                                 !loop.relative_pose->covariance.allFinite())) {
        return false;
      }
    }
    if (detector.database().size() < stored) return false;
    stored = detector.database().size();
  }
  return true;
}

}  // namespace fuzz
}  // namespace landmark_loop_closure
