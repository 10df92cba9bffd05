// Geometric-check benchmark on the generated corridor (two laps, drifting odometry, camera_info
// known): the whole detector with the shipped settings (config/default.yaml, then --config),
// run once per variant - check and gate on, check off, gate off, both off - on one core.
// Reports for each: loops published, true and false against the truth, recall of revisited
// keyframes; for the shipped variant also the time of keypoints + depths per keyframe and of the
// check per keyframe that ran it (median, p99), and the error of every metric relative pose.
//   lcd_bench_verification [--config config/demo.yaml] [--laps 2] [--min-score S]
// --min-score lowers the acceptance threshold to where false loops appear, to show what the
// check and the gate stop.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/descriptor.h"
#include "landmark_loop_closure/loop_detector.h"
#include "landmark_loop_closure/node_options.h"
#include "landmark_loop_closure/sim/sequence.h"
#include "landmark_loop_closure/yaml_parameter_source.h"

namespace {

using namespace landmark_loop_closure;

constexpr double kTrueLoopDistance = 2.5;  // Metres, as the demo report counts them.
constexpr double kRevisitMinSeconds = 20.0;

double percentile(std::vector<double> values, double fraction) {
  if (values.empty()) return NAN;
  const auto rank = static_cast<size_t>(fraction * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(rank),
                   values.end());
  return values[rank];
}

Eigen::Isometry3d cameraPose(const sim::Pose2D& body, const CameraMount& mount) {
  return planarPose(body.x, body.y, body.yaw).toIsometry() * mount.toPose().toIsometry();
}

struct Outcome {
  int keyframes = 0;
  int revisited = 0;
  int loops = 0;
  int true_loops = 0;
  int metric_poses = 0;
  std::vector<double> features_ms;
  std::vector<double> verify_ms;
  std::vector<double> translation_error_m;
  std::vector<double> rotation_error_deg;
};

Outcome run(const LoopDetectorOptions& options, double laps) {
  const sim::CorridorWorld world;
  const sim::CameraModel camera;
  sim::SequenceOptions sequence_options;
  sequence_options.laps = laps;
  sim::SequenceGenerator sequence(world, camera, sequence_options);
  LoopDetector detector(options, makeDescriptorExtractor(options.descriptor));
  std::map<uint64_t, sim::SequenceFrame> keyframe_truth;
  Outcome outcome;
  sim::SequenceFrame frame;
  while (sequence.next(&frame, false)) {
    const Pose odom = planarPose(frame.odom.x, frame.odom.y, frame.odom.yaw);
    const FrameAdmission admission =
        detector.admit(frame.stamp, odom, camera.width, camera.height, CV_8UC1);
    if (!admission.isKeyframe()) continue;
    const KeyframeResult result = detector.addKeyframe(admission.keyframe_id, frame.stamp, odom,
                                                       sequence.render(frame), camera.intrinsics());
    if (result.error) continue;
    ++outcome.keyframes;
    for (const auto& [id, earlier] : keyframe_truth) {
      if (frame.stamp - earlier.stamp >= kRevisitMinSeconds &&
          std::hypot(earlier.truth.x - frame.truth.x, earlier.truth.y - frame.truth.y) <
              kTrueLoopDistance) {
        ++outcome.revisited;
        break;
      }
    }
    keyframe_truth[result.keyframe_id] = frame;
    outcome.features_ms.push_back(result.times.features_ms);
    const bool checked = std::any_of(result.candidates.begin(), result.candidates.end(),
                                     [](const CandidateReport& report) {
                                       return report.verdict == CandidateVerdict::kAccepted ||
                                              report.verdict == CandidateVerdict::kGeometryRejected;
                                     });
    if (checked && options.verification.enabled)
      outcome.verify_ms.push_back(result.times.verify_ms);
    if (!result.loop) continue;
    ++outcome.loops;
    const sim::SequenceFrame& match = keyframe_truth.at(result.loop->match_id);
    outcome.true_loops += std::hypot(match.truth.x - frame.truth.x, match.truth.y - frame.truth.y) <
                          kTrueLoopDistance;
    if (result.loop->relative_pose && result.loop->relative_pose->metric) {
      ++outcome.metric_poses;
      const Eigen::Isometry3d truth = cameraPose(frame.truth, options.camera_mount).inverse() *
                                      cameraPose(match.truth, options.camera_mount);
      const RelativePose& estimate = *result.loop->relative_pose;
      outcome.translation_error_m.push_back((estimate.translation - truth.translation()).norm());
      outcome.rotation_error_deg.push_back(
          Eigen::AngleAxisd(estimate.rotation * truth.linear().transpose()).angle() * 180.0 / M_PI);
    }
  }
  return outcome;
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> arguments = {
      {"--config", ""}, {"--laps", "2"}, {"--min-score", ""}};
  for (int i = 1; i + 1 < argc; i += 2) arguments[argv[i]] = argv[i + 1];
  cv::setNumThreads(1);

  NodeOptions node_options;
  for (const std::string& path :
       {std::string(LANDMARK_LOOP_CLOSURE_SOURCE_DIR "/config/default.yaml"),
        arguments["--config"]}) {
    if (path.empty()) continue;
    const YamlParameterSource source = YamlParameterSource::fromFile(path);
    OptionReader reader(source);
    readNodeOptions(&reader, &node_options);
    if (!reader.errors().empty()) {
      std::fprintf(stderr, "%s: %s", path.c_str(), reader.errors().c_str());
      return 2;
    }
  }
  const double laps = std::stod(arguments["--laps"]);
  if (!arguments["--min-score"].empty()) {
    node_options.detector.acceptance.min_score = std::stod(arguments["--min-score"]);
  }

  struct Variant {
    const char* name;
    bool check;
    bool gate;
  };
  std::printf("Generated corridor, %.1f laps, min_score %.3f, one core\n\n", laps,
              node_options.detector.acceptance.min_score);
  std::printf("| variant | keyframes | revisited | loops | true | false | precision | recall |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  Outcome shipped;
  for (const Variant& variant :
       {Variant{"check + gate (shipped)", true, true}, Variant{"gate only", false, true},
        Variant{"check only", true, false}, Variant{"neither", false, false}}) {
    LoopDetectorOptions options = node_options.detector;
    options.verification.enabled = variant.check;
    options.odometry_gate.enabled = variant.gate;
    const Outcome outcome = run(options, laps);
    std::printf(
        "| %s | %d | %d | %d | %d | %d | %.3f | %.3f |\n", variant.name, outcome.keyframes,
        outcome.revisited, outcome.loops, outcome.true_loops, outcome.loops - outcome.true_loops,
        outcome.loops > 0 ? static_cast<double>(outcome.true_loops) / outcome.loops : NAN,
        outcome.revisited > 0 ? static_cast<double>(outcome.true_loops) / outcome.revisited : NAN);
    std::fflush(stdout);
    if (variant.check && variant.gate) shipped = outcome;
  }
  std::printf(
      "\nShipped variant, per keyframe: keypoints + depths median %.2f ms, p99 %.2f ms "
      "(%zu keyframes); geometric check + PnP median %.2f ms, p99 %.2f ms (%zu keyframes "
      "that ran it)\n",
      percentile(shipped.features_ms, 0.5), percentile(shipped.features_ms, 0.99),
      shipped.features_ms.size(), percentile(shipped.verify_ms, 0.5),
      percentile(shipped.verify_ms, 0.99), shipped.verify_ms.size());
  std::printf(
      "Metric relative poses: %d of %d loops; error median %.3f m / %.2f deg, 90th "
      "percentile %.3f m / %.2f deg, max %.3f m / %.2f deg\n",
      shipped.metric_poses, shipped.loops, percentile(shipped.translation_error_m, 0.5),
      percentile(shipped.rotation_error_deg, 0.5), percentile(shipped.translation_error_m, 0.9),
      percentile(shipped.rotation_error_deg, 0.9), percentile(shipped.translation_error_m, 1.0),
      percentile(shipped.rotation_error_deg, 1.0));
  return 0;
}
