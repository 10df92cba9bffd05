// Geometric-check benchmark: the whole detector with the shipped settings (config/default.yaml,
// then --config), run once per variant - check and gate on, check off, gate off, both off - on
// one core, on a sequence with true poses: the generated corridor (two laps, drifting odometry,
// camera_info known) or a KITTI odometry sequence (grey left images, poses, times, calib).
// Reports for each: loops published, true and false against the truth, recall of revisited
// keyframes; for the shipped variant also the time of keypoints + depths per keyframe and of the
// check per keyframe that ran it (median, p99), and the error of every metric relative pose.
//   lcd_bench_verification [--config config/demo.yaml] [--laps 2] [--min-score S]
//   lcd_bench_verification --kitti-images dataset/sequences/00/image_0 --kitti-poses
//       dataset/poses/00.txt --kitti-times dataset/sequences/00/times.txt --kitti-calib
//       dataset/sequences/00/calib.txt [--true-distance 5] [--variants shipped]
//   lcd_bench_verification --export-kitti DIR [--laps L]   (the corridor in KITTI's layout)
//   lcd_bench_verification --k1 -0.3 [--k2 0.1] [--lens handled|ignored] [--variants shipped]
//       (the corridor seen through a plumb_bob lens; the detector told of it, or not)
// --min-score lowers the acceptance threshold to where false loops appear, to show what the
// check and the gate stop. KITTI's true poses stand in for the odometry (no drift, so the gate
// has nothing to stop and triangulated depths are as good as the images allow); the camera sits
// on the body as camera_mount says.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <opencv2/imgcodecs.hpp>

#include "command_line.h"
#include "landmark_loop_closure/common/durable_file.h"
#include "landmark_loop_closure/common/model_directory.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/config/yaml_parameter_source.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/eval/evaluator.h"
#include "landmark_loop_closure/eval/ground_truth.h"
#include "landmark_loop_closure/eval/true_loop.h"
#include "landmark_loop_closure/sim/distorted_view.h"
#include "landmark_loop_closure/sim/sequence.h"

namespace {

using namespace landmark_loop_closure;

double percentile(std::vector<double> values, double fraction) {
  if (values.empty()) return NAN;
  const auto rank = static_cast<size_t>(fraction * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(rank),
                   values.end());
  return values[rank];
}

// One frame of a sequence: its odometry and, for scoring only, its camera's true pose.
struct BenchFrame {
  double stamp = 0.0;
  Pose odometry;
  Eigen::Isometry3d true_camera = Eigen::Isometry3d::Identity();
  size_t index = 0;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual bool next(BenchFrame* frame) = 0;
  virtual cv::Mat image(const BenchFrame& frame) const = 0;
  virtual CameraIntrinsics intrinsics() const = 0;
};

/// The lens of --k1/--k2 (plumb_bob): the corridor is rendered through it, and the detector is
/// told of it unless `ignored`.
struct CorridorLens {
  std::vector<double> coefficients;  ///< Empty: a pinhole camera.
  bool ignored = false;
};

class CorridorSource : public FrameSource {
 public:
  CorridorSource(double laps, const CameraMount& mount, const CorridorLens& lens = {})
      : sequence_(world_, camera_, optionsFor(laps)),
        mount_(mount.toPose().toIsometry()),
        lens_(lens) {
    if (!lens_.coefficients.empty()) {
      view_.emplace(world_, camera_, optionsFor(laps), lens_.coefficients);
    }
  }

  bool next(BenchFrame* frame) override {
    if (!sequence_.next(&current_, false)) return false;
    frame->stamp = current_.stamp;
    frame->odometry = planarPose(current_.odom.x, current_.odom.y, current_.odom.yaw);
    frame->true_camera =
        planarPose(current_.truth.x, current_.truth.y, current_.truth.yaw).toIsometry() * mount_;
    frame->index = frames_.size();
    frames_.push_back(current_);
    return true;
  }
  cv::Mat image(const BenchFrame& frame) const override {
    return view_ ? view_->render(frames_.at(frame.index))
                 : sequence_.render(frames_.at(frame.index));
  }
  CameraIntrinsics intrinsics() const override {
    return view_ && !lens_.ignored ? view_->intrinsics() : camera_.intrinsics();
  }

 private:
  static sim::SequenceOptions optionsFor(double laps) {
    sim::SequenceOptions options;
    options.laps = laps;
    return options;
  }

  const sim::CorridorWorld world_;
  const sim::CameraModel camera_;
  sim::SequenceGenerator sequence_;
  Eigen::Isometry3d mount_;
  CorridorLens lens_;
  std::optional<sim::DistortedView> view_;  ///< The lens, when there is one.
  sim::SequenceFrame current_;
  std::vector<sim::SequenceFrame> frames_;
};

// KITTI odometry: poses are the left camera's, in the first camera's frame; the body carrying the
// camera at `mount` stands in for the robot whose odometry the detector gets.
class KittiSource : public FrameSource {
 public:
  KittiSource(const std::string& images, const std::string& poses, const std::string& times,
              const std::string& calib, const CameraMount& mount)
      : paths_(eval::listImages(images)),
        poses_(eval::readKittiPoses(poses)),
        stamps_(eval::readNumbers(times)),
        mount_(mount.toPose().toIsometry()) {
    if (paths_.empty()) throw std::invalid_argument("no images in " + images);
    if (poses_.size() != paths_.size() || stamps_.size() != paths_.size()) {
      throw std::invalid_argument(std::to_string(paths_.size()) + " images, " +
                                  std::to_string(poses_.size()) + " poses and " +
                                  std::to_string(stamps_.size()) + " times do not match");
    }
    const cv::Mat first = cv::imread(paths_.front(), cv::IMREAD_GRAYSCALE);
    if (first.empty()) throw std::invalid_argument("cannot read " + paths_.front());
    intrinsics_ = eval::readKittiIntrinsics(calib, "P0", first.size());
  }

  bool next(BenchFrame* frame) override {
    if (next_ >= paths_.size()) return false;
    frame->index = next_++;
    frame->stamp = stamps_[frame->index];
    frame->true_camera = poses_[frame->index].toIsometry();
    frame->odometry = Pose::fromIsometry(frame->true_camera * mount_.inverse());
    return true;
  }
  cv::Mat image(const BenchFrame& frame) const override {
    return cv::imread(paths_.at(frame.index), cv::IMREAD_GRAYSCALE);
  }
  CameraIntrinsics intrinsics() const override { return intrinsics_; }

 private:
  std::vector<std::string> paths_;
  std::vector<Pose> poses_;
  std::vector<double> stamps_;
  Eigen::Isometry3d mount_;
  CameraIntrinsics intrinsics_;
  size_t next_ = 0;
};

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

Outcome run(const LoopDetectorOptions& options, FrameSource* source,
            const eval::TrueLoopRule& rule) {
  LoopDetector detector(options, makeDescriptorExtractor(options.descriptor));
  const CameraIntrinsics intrinsics = source->intrinsics();
  const cv::Size size = intrinsics.image_size;
  std::map<uint64_t, BenchFrame> keyframe_truth;
  Outcome outcome;
  BenchFrame frame;
  const auto true_loop = [&rule](const BenchFrame& query, const BenchFrame& match) {
    return rule.isTrueLoop(query.true_camera.translation(), query.stamp,
                           match.true_camera.translation(), match.stamp);
  };
  while (source->next(&frame)) {
    const FrameAdmission admission =
        detector.admit(frame.stamp, frame.odometry, size.width, size.height, CV_8UC1);
    if (!admission.isKeyframe()) continue;
    const KeyframeResult result = detector.addKeyframe(
        admission.keyframe_id, frame.stamp, frame.odometry, source->image(frame), intrinsics);
    if (result.error) continue;
    ++outcome.keyframes;
    for (const auto& [id, earlier] : keyframe_truth) {
      if (true_loop(frame, earlier)) {
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
    const BenchFrame& match = keyframe_truth.at(result.loop->match_id);
    outcome.true_loops += true_loop(frame, match) ? 1 : 0;
    if (result.loop->relative_pose && result.loop->relative_pose->metric) {
      ++outcome.metric_poses;
      const Eigen::Isometry3d truth = frame.true_camera.inverse() * match.true_camera;
      const RelativePose& estimate = *result.loop->relative_pose;
      outcome.translation_error_m.push_back((estimate.translation - truth.translation()).norm());
      outcome.rotation_error_deg.push_back(
          Eigen::AngleAxisd(estimate.rotation * truth.linear().transpose()).angle() * 180.0 / M_PI);
    }
  }
  return outcome;
}

// Writes a sequence as KITTI odometry lays it out: image_0/NNNNNN.png, poses.txt (camera poses
// relative to the first camera), times.txt, calib.txt (P0).
void exportKitti(FrameSource* source, const std::string& folder) {
  namespace fs = std::filesystem;
  fs::create_directories(fs::path(folder) / "image_0");
  DurableText poses((fs::path(folder) / "poses.txt").string());
  DurableText times((fs::path(folder) / "times.txt").string());
  DurableText calib((fs::path(folder) / "calib.txt").string());
  const CameraIntrinsics k = source->intrinsics();
  calib.precision(12);
  calib << "P0: " << k.fx << " 0 " << k.cx << " 0 0 " << k.fy << " " << k.cy << " 0 0 0 1 0\n";
  poses.precision(12);
  times.precision(12);
  BenchFrame frame;
  std::optional<Eigen::Isometry3d> first;
  while (source->next(&frame)) {
    if (!first) first = frame.true_camera;
    const Eigen::Matrix<double, 3, 4> pose =
        (first->inverse() * frame.true_camera).matrix().topRows<3>();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) poses << pose(r, c) << (r == 2 && c == 3 ? "\n" : " ");
    }
    times << frame.stamp << "\n";
    char name[32];
    std::snprintf(name, sizeof(name), "%06zu.png", frame.index);
    writeImageDurably((fs::path(folder) / "image_0" / name).string(), source->image(frame));
  }
  calib.commit();
  poses.commit();
  times.commit();
}

}  // namespace

int main(int argc, char** argv) try {
  std::string config, kitti_images, kitti_poses, kitti_times, kitti_calib, export_folder;
  std::string variants = "all", lens_use = "handled";
  double laps = 2.0;
  std::optional<double> min_score, true_distance_m, k1;
  double k2 = 0.0;
  CLI::App app{
      "The whole detector with and without its geometric check and odometry gate, on the "
      "generated corridor or a KITTI sequence: loops true and false, recall, time of the check."};
  app.add_option("--config", config, "the node's parameters over config/default.yaml");
  app.add_option("--laps", laps, "corridor: laps driven")->capture_default_str();
  app.add_option("--min-score", min_score, "acceptance threshold instead of the config's");
  app.add_option("--kitti-images", kitti_images,
                 "KITTI: image_0 folder (run KITTI, not the corridor)");
  app.add_option("--kitti-poses", kitti_poses, "KITTI: poses file");
  app.add_option("--kitti-times", kitti_times, "KITTI: times file");
  app.add_option("--kitti-calib", kitti_calib, "KITTI: calib file");
  app.add_option("--true-distance", true_distance_m,
                 "a loop is true within this many metres (default 2.5, KITTI 5)");
  app.add_option("--variants", variants, "all, or shipped alone")
      ->check(CLI::IsMember({"all", "shipped"}))
      ->capture_default_str();
  app.add_option("--export-kitti", export_folder, "write the corridor in KITTI's layout and exit");
  app.add_option("--k1", k1, "corridor: seen through a plumb_bob lens with this k1");
  app.add_option("--k2", k2, "...and this k2")->capture_default_str();
  app.add_option("--lens", lens_use, "the detector told of the lens (handled) or not (ignored)")
      ->check(CLI::IsMember({"handled", "ignored"}))
      ->capture_default_str();
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  cv::setNumThreads(1);

  NodeOptions node_options;
  for (const std::string& path : {defaultConfigFile(), config}) {
    if (path.empty()) continue;
    const YamlParameterSource source = YamlParameterSource::fromFile(path);
    OptionReader reader(source);
    readNodeOptions(&reader, &node_options);
    if (!reader.errors().empty()) {
      std::fprintf(stderr, "%s: %s", path.c_str(), reader.errors().c_str());
      return 2;
    }
  }
  const bool kitti = !kitti_images.empty();
  const double true_distance =
      true_distance_m ? *true_distance_m : (kitti ? 5.0 : 2.5);  // The demo report's 2.5 m.
  const CameraMount& mount = node_options.detector.camera_mount;
  CorridorLens lens;
  if (k1) {
    lens.coefficients = {*k1, k2, 0.0, 0.0, 0.0};
    lens.ignored = lens_use == "ignored";
  }
  const auto makeSource = [&]() -> std::unique_ptr<FrameSource> {
    if (!kitti) return std::make_unique<CorridorSource>(laps, mount, lens);
    return std::make_unique<KittiSource>(kitti_images, kitti_poses, kitti_times, kitti_calib,
                                         mount);
  };
  if (min_score) node_options.detector.acceptance.min_score = *min_score;

  struct Variant {
    const char* name;
    bool check;
    bool gate;
  };
  if (!export_folder.empty()) {
    CorridorSource corridor(laps, mount);
    exportKitti(&corridor, export_folder);
    return 0;
  }
  if (kitti) {
    std::printf("KITTI %s, true loops within %.1f m, min_score %.3f, one core\n\n",
                kitti_images.c_str(), true_distance, node_options.detector.acceptance.min_score);
  } else {
    std::printf("Generated corridor, %.1f laps, min_score %.3f, one core", laps,
                node_options.detector.acceptance.min_score);
    if (!lens.coefficients.empty()) {
      std::printf(", lens k1 %.3f k2 %.3f (plumb_bob), %s by the detector", lens.coefficients[0],
                  lens.coefficients[1], lens.ignored ? "ignored" : "handled");
    }
    std::printf("\n\n");
  }
  std::printf("| variant | keyframes | revisited | loops | true | false | precision | recall |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  Outcome shipped;
  for (const Variant& variant :
       {Variant{"check + gate (shipped)", true, true}, Variant{"gate only", false, true},
        Variant{"check only", true, false}, Variant{"neither", false, false}}) {
    const bool is_shipped = variant.check && variant.gate;
    if (variants == "shipped" && !is_shipped) continue;
    LoopDetectorOptions options = node_options.detector;
    options.verification.enabled = variant.check;
    options.odometry_gate.enabled = variant.gate;
    const std::unique_ptr<FrameSource> source = makeSource();
    const Outcome outcome = run(options, source.get(),
                                eval::TrueLoopRule{true_distance, eval::TrueLoopRule{}.min_gap_s});
    std::printf(
        "| %s | %d | %d | %d | %d | %d | %.3f | %.3f |\n", variant.name, outcome.keyframes,
        outcome.revisited, outcome.loops, outcome.true_loops, outcome.loops - outcome.true_loops,
        outcome.loops > 0 ? static_cast<double>(outcome.true_loops) / outcome.loops : NAN,
        outcome.revisited > 0 ? static_cast<double>(outcome.true_loops) / outcome.revisited : NAN);
    std::fflush(stdout);
    if (is_shipped) shipped = outcome;
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
} catch (const std::exception& error) {
  std::fprintf(stderr, "lcd_bench_verification: %s\n", error.what());
  return 2;
}
