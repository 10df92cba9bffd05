#include "evaluate_detector.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <sstream>

#include <Eigen/Core>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "bag/bag_source.h"
#include "landmark_loop_closure/config/node_options.h"
#include "landmark_loop_closure/config/yaml_parameter_source.h"
#include "landmark_loop_closure/eval/trajectory_error.h"
#include "landmark_loop_closure/eval/true_loop.h"
#include "landmark_loop_closure/sim/distorted_view.h"
#include "landmark_loop_closure/sim/sequence.h"

namespace landmark_loop_closure {
namespace tools {

namespace {

void warnUnknownKeys(const YamlParameterSource& source, const OptionReader& reader,
                     const std::string& path) {
  for (const std::string& note : parameterNotes(source.keys(), reader)) {
    std::fprintf(stderr, "lcd_evaluate: %s: %s\n", path.c_str(), note.c_str());
  }
}

NodeOptions readConfig(const std::string& path) {
  NodeOptions node;
  // No file: an empty one, read as the node reads its parameters (the network's description,
  // the fallback without it), so that the built-in defaults run as the node runs them.
  const YamlParameterSource source =
      path.empty() ? YamlParameterSource(YAML::Node()) : YamlParameterSource::fromFile(path);
  OptionReader reader(source);
  readEvaluationOptions(&reader, &node);
  if (!path.empty()) warnUnknownKeys(source, reader, path);
  const std::string problems = reader.errors() + node.validate();
  if (!problems.empty()) throw std::invalid_argument(path + ":\n" + problems);
  if (!node.fallback_warning.empty()) {
    std::fprintf(stderr, "lcd_evaluate: %s\n", node.fallback_warning.c_str());
  }
  if (!node.ignored_warning.empty()) {
    std::fprintf(stderr, "lcd_evaluate: %s\n", node.ignored_warning.c_str());
  }
  return node;
}

// The pose graph's parameters (config/pose_graph.yaml's layout) for the trajectory error.
PoseGraphOptions readPoseGraphConfig(const std::string& path) {
  PoseGraphNodeOptions options;
  if (path.empty()) return options.graph;
  const YamlParameterSource source = YamlParameterSource::fromFile(path);
  OptionReader reader(source);
  PoseGraphNodeOptions::parameters().read(&reader, &options);
  warnUnknownKeys(source, reader, path);
  const std::string problems = reader.errors() + options.validate();
  if (!problems.empty()) throw std::invalid_argument(path + ":\n" + problems);
  return options.graph;
}

void printPass(const char* label, const eval::DetectorPass& pass) {
  std::printf("  %-12s min_score %.3f: %zu loops, %zu true, precision %.3f, recall %.3f\n", label,
              pass.min_score, pass.loops.size(), pass.true_loops, pass.precision, pass.recall);
}

}  // namespace

eval::MatchChecks matchChecks(const std::string& config, const CameraIntrinsics& intrinsics) {
  const NodeOptions options = readConfig(config);
  eval::MatchChecks checks;
  checks.appearance = options.detector.appearance;
  checks.geometry = options.detector.verification;
  checks.intrinsics = intrinsics;
  return checks;
}

namespace {

// Image-only sequences: whether the camera moved since the last frame that did, judged by the
// mean absolute difference of the grey images at 64 px wide (a stopped train's or robot's frames
// differ by noise, under 2 grey levels on Nordland; moving ones by 14 and more).
constexpr int kStillWidth = 64;

cv::Mat stillPicture(const cv::Mat& image) {
  if (image.empty()) return cv::Mat();
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  const int height = std::max(1, image.rows * kStillWidth / std::max(1, image.cols));
  cv::Mat small;
  cv::resize(grey, small, cv::Size(kStillWidth, height), 0, 0, cv::INTER_AREA);
  small.convertTo(small, CV_32F);
  return small;
}

// Mean absolute grey difference; infinite when the pictures' sizes differ.
double pictureDifference(const cv::Mat& a, const cv::Mat& b) {
  if (a.empty() || b.empty() || a.size() != b.size()) return INFINITY;
  return cv::mean(cv::abs(a - b))[0];
}

class StandstillDetector {
 public:
  explicit StandstillDetector(double threshold) : threshold_(threshold) {}
  bool moved(const cv::Mat& image) {
    if (threshold_ <= 0.0) return true;
    cv::Mat small = stillPicture(image);
    if (pictureDifference(small, last_moving_) < threshold_) return false;
    last_moving_ = small;
    return true;
  }

 private:
  double threshold_;
  cv::Mat last_moving_;
};

}  // namespace

std::vector<bool> jointStops(const std::vector<std::string>& first,
                             const std::vector<std::string>& second, double threshold) {
  const size_t frames = std::min(first.size(), second.size());
  std::vector<bool> stopped(frames, false);
  cv::Mat previous_first, previous_second;
  for (size_t i = 0; i < frames; ++i) {
    const cv::Mat a = stillPicture(cv::imread(first[i], cv::IMREAD_GRAYSCALE));
    const cv::Mat b = stillPicture(cv::imread(second[i], cv::IMREAD_GRAYSCALE));
    stopped[i] = i > 0 && pictureDifference(a, previous_first) < threshold &&
                 pictureDifference(b, previous_second) < threshold;
    previous_first = a;
    previous_second = b;
  }
  return stopped;
}

DetectorSource imageSequenceSource(const std::vector<std::string>& paths,
                                   const eval::GroundTruth& truth, const std::vector<Pose>& poses,
                                   const std::vector<double>& stamps,
                                   const CameraIntrinsics& intrinsics, double still_threshold,
                                   int image_width, const std::vector<bool>& standing,
                                   const ImageRuns& runs) {
  DetectorSource source;
  source.protocol =
      poses.empty() && !runs.starts.empty() ? runs.protocol : eval::RunProtocol::kOneSequence;
  // Robots: each traversal another robot, its odometry its own, as a session's.
  const bool sessions = source.protocol == eval::RunProtocol::kSessions ||
                        source.protocol == eval::RunProtocol::kRobots;
  const bool one_run = source.protocol == eval::RunProtocol::kOneRun;
  source.has_intrinsics = intrinsics.valid();
  if (!poses.empty() && (poses.size() != paths.size() || stamps.size() != paths.size())) {
    throw std::invalid_argument("there are " + std::to_string(paths.size()) + " images but " +
                                std::to_string(poses.size()) + " poses and " +
                                std::to_string(stamps.size()) + " stamps");
  }
  source.has_odometry = !poses.empty();
  source.description =
      source.has_odometry
          ? "image sequence with poses and stamps as odometry (keyframe rule and odometry gate "
            "on), "
            "resized to the first image's size"
          : "image-only sequence: images 1 s apart, each 1 m further on a straight path unless " +
                (standing.empty()
                     ? "it barely differs from the last moving one (mean grey difference under " +
                           std::to_string(still_threshold).substr(0, 4) + " at 64 px wide)"
                     : std::string("both traversals stand there (a joint stop, as --gt-stops "
                                   "finds them)")) +
                ": standing still, no keyframe, as odometry would add none; " +
                (sessions
                     ? std::string(source.protocol == eval::RunProtocol::kRobots
                                       ? "each traversal another robot (a detector and a "
                                         "map of its own, searching the earlier robots' "
                                         "shared rows), "
                                       : "") +
                           "each traversal its own session, its odometry from the origin with a "
                           "heading drifting " +
                           std::to_string(runs.heading_drift).substr(0, 6) +
                           " rad per step (random walk), the odometry gate on"
                 : one_run
                     ? "one session, one odometry throughout: the route taken as a closed loop "
                       "of the first traversal's steps, so the next begins where it began, the "
                       "heading drifting " +
                           std::to_string(runs.heading_drift).substr(0, 6) +
                           " rad per step (random walk) all the way, the odometry gate on"
                 : source.protocol == eval::RunProtocol::kLocalisation
                     ? "the first traversal mapped, the next localised in it (mode "
                       "localization)"
                     : "one session, no odometry, so the odometry gate is off") +
                "; resized to the first image's size";
  source.gate_without_poses = sessions || one_run;
  if (source.has_intrinsics) {
    std::ostringstream camera;
    camera << "; pinhole fx " << intrinsics.fx << " fy " << intrinsics.fy << " cx " << intrinsics.cx
           << " cy " << intrinsics.cy << " at " << intrinsics.image_size.width << "x"
           << intrinsics.image_size.height;
    source.description += camera.str();
  }
  if (image_width > 0) {
    source.description += "; every image scaled to " + std::to_string(image_width) + " px wide";
  }
  source.play = [paths, poses, stamps, intrinsics, still_threshold, image_width, standing, runs,
                 protocol = source.protocol](
                    bool colour,
                    const std::function<void(size_t, const eval::DetectorFrame&)>& sink) {
    cv::Size size;
    StandstillDetector standstill(still_threshold);
    double travelled = -1.0;
    // kSessions, kOneRun: drifting odometry, the same in every pass.
    std::mt19937 random(7);
    std::normal_distribution<double> heading_error(0.0, runs.heading_drift);
    Eigen::Vector2d position(-1.0, 0.0);
    double heading = 0.0;
    // kOneRun: the route is a closed loop of as many 1 m steps as the first run moves, so the
    // next run begins where the first began, the odometry drifting on all the way round.
    size_t lap_steps = 0;
    if (protocol == eval::RunProtocol::kOneRun && !runs.starts.empty()) {
      lap_steps = runs.starts.front();
      for (size_t i = 0; i < std::min(standing.size(), runs.starts.front()); ++i) {
        if (standing[i]) --lap_steps;
      }
    }
    const double turn_per_step = lap_steps > 0 ? 2.0 * M_PI / static_cast<double>(lap_steps) : 0.0;
    for (size_t i = 0; i < paths.size(); ++i) {
      eval::DetectorFrame frame;
      frame.new_run = protocol != eval::RunProtocol::kOneSequence &&
                      std::find(runs.starts.begin(), runs.starts.end(), i) != runs.starts.end();
      if (frame.new_run &&
          (protocol == eval::RunProtocol::kSessions || protocol == eval::RunProtocol::kRobots)) {
        position = Eigen::Vector2d(-1.0, 0.0);
        heading = 0.0;
      }
      frame.stamp = stamps.empty() ? 1.0 + static_cast<double>(i) : stamps[i];
      frame.image = eval::readImage(paths[i], colour, image_width);
      if (frame.image.empty()) {
        std::fprintf(stderr, "lcd_evaluate: skipped an image that does not decode: %s\n",
                     paths[i].c_str());
        continue;
      }
      if (poses.empty()) {
        const bool moved = standing.empty() ? standstill.moved(frame.image)
                                            : !(i < standing.size() && standing[i]);
        if (moved) travelled += 1.0;
        frame.pose.position = Eigen::Vector3d(travelled, 0.0, 0.0);
        if (protocol == eval::RunProtocol::kSessions || protocol == eval::RunProtocol::kOneRun ||
            protocol == eval::RunProtocol::kRobots) {
          if (moved) {
            heading += turn_per_step + heading_error(random);
            position += Eigen::Vector2d(std::cos(heading), std::sin(heading));
          }
          frame.pose = planarPose(position.x(), position.y(), heading);
        }
      } else {
        frame.pose = poses[i];
      }
      // A camera keeps its size; traversals filmed at other sizes are resized to the first's.
      if (size.empty()) size = frame.image.size();
      if (frame.image.size() != size)
        cv::resize(frame.image, frame.image, size, 0, 0, cv::INTER_AREA);
      if (intrinsics.valid()) frame.intrinsics = intrinsics.scaledTo(size);
      sink(i, frame);
    }
  };
  source.same_place = [truth](size_t query, size_t match) { return truth.contains(query, match); };
  // Each run's centre until the caller sets the tolerance the truth allows (lcd_evaluate does).
  source.offset = [truth](size_t query, size_t match) {
    return framesFromTruth(truth, query, match, HUGE_VAL);
  };
  source.offset_unit = "frames";
  return source;
}

namespace {

// True poses and stamps by frame index, filled as the frames are played.
struct FrameTruth {
  std::vector<Pose> poses;
  std::vector<double> stamps;
  void set(size_t index, const Pose& pose, double stamp) {
    if (poses.size() <= index) {
      poses.resize(index + 1);
      stamps.resize(index + 1);
    }
    poses[index] = pose;
    stamps[index] = stamp;
  }
};

std::function<double(size_t, size_t)> metresApart(std::shared_ptr<FrameTruth> truth) {
  return [truth](size_t query, size_t match) {
    return (truth->poses[query].position - truth->poses[match].position).norm();
  };
}

eval::SamePlace trueLoops(std::shared_ptr<FrameTruth> truth, const eval::TrueLoopRule& rule) {
  return [truth, rule](size_t query, size_t match) {
    return rule.isTrueLoop(truth->poses[query].position, truth->stamps[query],
                           truth->poses[match].position, truth->stamps[match]);
  };
}

}  // namespace

DetectorSource corridorSource(double laps, const CorridorRun& run) {
  DetectorSource source;
  source.description =
      std::string(run.aliasing ? "generated aliasing corridor (bays that look alike every 4 m, a "
                                 "wide lens: plumb_bob k1 -0.3 k2 0.1)"
                               : "generated corridor") +
      ", " + std::to_string(laps).substr(0, 4) +
      " laps at 10 Hz: drifting odometry, camera intrinsics; " +
      (run.protocol == eval::RunProtocol::kRobots
           ? "the second lap another robot (its own detector, map and odometry from the origin, "
             "searching the first robot's shared rows); "
       : run.protocol == eval::RunProtocol::kSessions
           ? "the second lap its own session, its odometry restarted at the origin; "
       : run.protocol == eval::RunProtocol::kLocalisation
           ? "the second lap localised in the first lap's map (mode localization); "
           : "") +
      (run.odometry_jump_at_laps > 0.0
           ? "tracking lost at " + std::to_string(run.odometry_jump_at_laps).substr(0, 4) +
                 " laps (the odometry jumps into another frame); "
           : std::string()) +
      "a loop is true " + eval::TrueLoopRule{}.describe() + " (the truth's positions)";
  source.protocol = run.protocol;
  source.has_intrinsics = true;
  source.has_odometry = true;
  auto truth = std::make_shared<FrameTruth>();
  source.play = [laps, run, truth](
                    bool colour,
                    const std::function<void(size_t, const eval::DetectorFrame&)>& sink) {
    sim::CorridorWorld::Options world_options;
    if (run.aliasing) world_options.bay_length = 4.0;
    const sim::CorridorWorld world(world_options);
    const sim::CameraModel camera;
    sim::SequenceOptions options;
    options.laps = laps;
    sim::SequenceGenerator sequence(world, camera, options);
    std::unique_ptr<sim::DistortedView> lens;
    if (run.aliasing) {
      lens = std::make_unique<sim::DistortedView>(world, camera, options,
                                                  std::vector<double>{-0.3, 0.1, 0.0, 0.0, 0.0});
    }
    const CameraIntrinsics intrinsics = lens ? lens->intrinsics() : camera.intrinsics();
    const size_t jump_frame = run.odometry_jump_at_laps > 0.0
                                  ? static_cast<size_t>(static_cast<double>(sequence.size()) *
                                                        run.odometry_jump_at_laps / laps)
                                  : sequence.size();
    const Eigen::Isometry3d jumped_frame = Eigen::Translation3d(40.0, -25.0, 0.0) *
                                           Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
    sim::SequenceFrame frame;
    int lap = 0;
    Eigen::Isometry3d run_origin = Eigen::Isometry3d::Identity();
    while (sequence.next(&frame, !lens)) {
      truth->set(frame.index, planarPose(frame.truth.x, frame.truth.y, frame.truth.yaw),
                 frame.stamp);
      eval::DetectorFrame played;
      played.stamp = frame.stamp;
      const Pose odometry = planarPose(frame.odom.x, frame.odom.y, frame.odom.yaw);
      played.new_run =
          run.protocol != eval::RunProtocol::kOneSequence && frame.lap == 1 && lap == 0;
      lap = frame.lap;
      if (played.new_run && (run.protocol == eval::RunProtocol::kSessions ||
                             run.protocol == eval::RunProtocol::kRobots)) {
        run_origin = odometry.toIsometry();
      }
      played.pose = Pose::fromIsometry(run_origin.inverse() * odometry.toIsometry());
      if (frame.index >= jump_frame) {
        played.pose = Pose::fromIsometry(jumped_frame * played.pose.toIsometry());
      }
      const cv::Mat image = lens ? lens->render(frame) : frame.image;
      if (colour) {
        cv::cvtColor(image, played.image, cv::COLOR_GRAY2BGR);
      } else {
        played.image = image;
      }
      played.intrinsics = intrinsics;
      sink(frame.index, played);
    }
  };
  source.same_place = trueLoops(truth, eval::TrueLoopRule{});
  source.true_pose = [truth](size_t frame) { return truth->poses.at(frame); };
  source.offset = metresApart(truth);
  source.offset_unit = "m";
  source.offset_tolerance = eval::TrueLoopRule{}.max_distance_m;
  return source;
}

DetectorSource bagSource(const std::string& path, const std::string& image_topic,
                         const std::string& odom_topic, const std::string& truth_topic,
                         double distance, double gap) {
  DetectorSource source;
  const eval::TrueLoopRule rule{distance, gap};
  source.description =
      "bag " + path + ": every image with its odometry and camera_info; a loop is true " +
      rule.describe() + " (" +
      (truth_topic.empty() ? "the odometry's positions: no --truth-topic, and it drifts"
                           : "the truth topic's positions") +
      ")";
  source.has_intrinsics = true;  // When the bag has camera_info; loops go unverified otherwise.
  source.has_odometry = true;
  auto truth = std::make_shared<FrameTruth>();
  BagSourceOptions options;
  options.path = path;
  options.image_topic = image_topic;
  options.odom_topic = odom_topic;
  options.truth_topic = truth_topic;
  source.play = [options, truth](
                    bool colour,
                    const std::function<void(size_t, const eval::DetectorFrame&)>& sink) {
    playBagFrames(options, colour,
                  [&](size_t index, const eval::DetectorFrame& frame, const Pose& true_pose) {
                    truth->set(index, true_pose, frame.stamp);
                    sink(index, frame);
                  });
  };
  source.same_place = trueLoops(truth, rule);
  source.offset = metresApart(truth);
  source.offset_unit = "m";
  source.offset_tolerance = rule.max_distance_m;
  // Without a truth topic the "truth" is the odometry itself: no trajectory error to report.
  if (!truth_topic.empty())
    source.true_pose = [truth](size_t frame) { return truth->poses.at(frame); };
  return source;
}

// Several sessions (odometry frames) in one graph: each session's keyframes in the frame of the
// whole (one similarity fit of every keyframe), against each session on its own (its odometry
// fitted alone: what a graph per session gives when no loop corrects it).
void printSessions(const eval::DetectorEvaluation& result, const eval::PoseGraphReplay& replay,
                   const std::vector<Pose>& truth) {
  std::printf(
      "  sessions: %zu chains in the pose graph, %zu joined to the first by loops; %zu metric "
      "loops between sessions, %zu accepted\n",
      replay.chains, replay.chains_joined, replay.cross_session_loops,
      replay.cross_session_loops_accepted);
  const std::vector<double> in_one_frame = eval::similarityAlignedErrors(replay.corrected, truth);
  std::map<uint32_t, std::vector<size_t>> keyframes_of;
  for (size_t id = 0; id < result.keyframe_sessions.size() && id < truth.size(); ++id) {
    keyframes_of[result.keyframe_sessions[id]].push_back(id);
  }
  for (const auto& [session, ids] : keyframes_of) {
    double sum = 0.0, worst = 0.0;
    std::vector<Pose> odometry, session_truth;
    for (const size_t id : ids) {
      sum += in_one_frame[id] * in_one_frame[id];
      worst = std::max(worst, in_one_frame[id]);
      odometry.push_back(result.keyframe_poses[id]);
      session_truth.push_back(truth[id]);
    }
    const eval::TrajectoryError alone = eval::trajectoryError(odometry, session_truth);
    std::printf(
        "  session %u: %zu keyframes; corrected, in one frame with the others (similarity fit "
        "of all): RMSE %.3f m, largest %.3f m; its odometry fitted alone: RMSE %.3f m (first "
        "pose aligned %.3f m)\n",
        session, ids.size(), std::sqrt(sum / static_cast<double>(ids.size())), worst,
        alone.similarity_rmse, alone.first_pose_rmse);
  }
}

// The keyframes' odometry, and the same corrected by the reference pose graph with the metric
// loops of the configured pass, against the truth (what the demo's summary reports).
void printTrajectoryError(const eval::DetectorEvaluation& result,
                          const std::function<Pose(size_t frame)>& true_pose,
                          const PoseGraphOptions& graph_options) {
  std::vector<Pose> truth;
  for (const size_t frame : result.keyframe_frames) truth.push_back(true_pose(frame));
  const eval::PoseGraphReplay replay = eval::replayIntoPoseGraph(result, graph_options);
  const eval::TrajectoryError odometry = eval::trajectoryError(result.keyframe_poses, truth);
  const eval::TrajectoryError corrected = eval::trajectoryError(replay.corrected, truth);
  std::printf(
      "  trajectory RMSE: odometry %.3f m, corrected by the pose graph %.3f m (first pose "
      "aligned); best similarity fit %.3f m and %.3f m (scale %.3f and %.3f); %zu metric loops "
      "given to the graph, %zu refused (%zu of them true)\n",
      odometry.first_pose_rmse, corrected.first_pose_rmse, odometry.similarity_rmse,
      corrected.similarity_rmse, odometry.scale, corrected.scale, replay.metric_loops,
      replay.refused_loops, replay.refused_true_loops);
  if (replay.chains > 1) printSessions(result, replay, truth);
  if (graph_options.heading_drift_prior_sd_per_m > 0.0) {
    std::printf("  odometry heading drift estimated by the pose graph: %.5f rad/m\n",
                replay.heading_drift_per_m);
  }
}

int runDetectorMode(const Arguments& arguments, const DetectorSource& source,
                    const std::string& dataset, const std::string& output_folder) {
  const std::string config = arguments.get("--config");
  NodeOptions node = readConfig(config);
  LoopDetectorOptions options = node.detector;
  std::printf("detector: %s\n  config %s\n  %s\n", dataset.c_str(),
              config.empty() ? "built-in defaults (= config/default.yaml)" : config.c_str(),
              source.description.c_str());
  if (arguments.has("--dry-run")) {
    std::printf("  dry run: arguments, config and data read; nothing evaluated\n");
    return 0;
  }
  if (!source.has_odometry && !source.gate_without_poses) options.odometry_gate.enabled = false;
  if (!source.has_intrinsics && options.verification.enabled) {
    std::printf(
        "  no camera intrinsics: no ORB check (--camera-info); %s\n",
        options.appearance.enabled ? "the appearance check still runs" : "loops go unverified");
  }
  if (!source.has_odometry) {
    // Every image is a keyframe 1 m from the last.
    options.keyframe.min_motion = std::min(options.keyframe.min_motion, 0.5);
    options.keyframe.max_motion = std::max(options.keyframe.max_motion, 2.0);
    options.metric_pose.triangulate_from_odometry = false;
  }
  const std::vector<std::string> names = arguments.has("--descriptors")
                                             ? splitList(arguments.get("--descriptors"))
                                             : std::vector<std::string>{options.descriptor.type};
  eval::DetectorEvaluationOptions evaluation_options;
  evaluation_options.sweep_steps = static_cast<int>(arguments.number("--sweep-steps", 16));
  evaluation_options.protocol = source.protocol;
  evaluation_options.fleet = node.fleet;  // --protocol robots: the config's fleet/ keys.
  for (const std::string& name : names) {
    Variant variant = descriptorVariant(name, arguments, options.descriptor);
    Training none;  // The detector learns nothing from its own frames here.
    LoopDetectorOptions run_options = options;
    std::shared_ptr<const DescriptorExtractor> extractor =
        makeVariantExtractor(&variant, name, none, output_folder);
    run_options.descriptor = variant.options;
    const bool colour = extractor->wantsColour();
    cv::Size first_image;  // What the node would log at its first image.
    const eval::FramePlayer play =
        [&source, colour,
         &first_image](const std::function<void(size_t, const eval::DetectorFrame&)>& sink) {
          source.play(colour, [&](size_t index, const eval::DetectorFrame& frame) {
            if (first_image.empty()) first_image = frame.image.size();
            sink(index, frame);
          });
        };
    const auto progress = [name](size_t done, size_t total) {
      if (total == 0) {
        std::fprintf(stderr, "lcd_evaluate: detector (%s): frame %zu\n", name.c_str(), done);
      } else {
        std::fprintf(stderr, "lcd_evaluate: detector (%s): threshold pass %zu of at most %zu\n",
                     name.c_str(), done, total);
      }
    };
    const eval::DetectorEvaluation result = eval::evaluateDetector(
        run_options, extractor, play, source.same_place, evaluation_options, progress);
    const std::string label = names.size() == 1 && !arguments.has("--name-suffix")
                                  ? name
                                  : name + arguments.get("--name-suffix");
    std::printf("%s: %zu frames, %zu keyframes (%zu refused), %zu revisit a place\n", label.c_str(),
                result.frames, result.keyframes, result.refused_frames, result.revisits);
    if (!first_image.empty()) {
      std::printf("  descriptor %s\n", extractor->describesAs(first_image).c_str());
    }
    printPass("configured", result.configured);
    if (const std::string histogram = offsetHistogram(result.configured.loops, source);
        !histogram.empty()) {
      std::printf("%s\n", histogram.c_str());
    }
    // The headline pair: what the configuration publishes, and the best it could without a
    // false loop (a threshold chosen knowing the truth).
    std::printf("  headline: recall %.3f at the configuration (%zu false loops), ",
                result.configured.recall,
                result.configured.loops.size() - result.configured.true_loops);
    if (result.recall_at_100_precision < 0.0) {
      std::printf("R@100P not swept (--sweep-steps 0)  keyframe %.2f/%.2f ms (median/p99)\n",
                  result.keyframe_ms.median, result.keyframe_ms.p99);
    } else
      std::printf(
          "R@100P %.3f (min_score %.3f)  keyframe %.2f/%.2f ms (median/p99, whole "
          "pipeline)\n",
          result.recall_at_100_precision, result.threshold_at_100_precision,
          result.keyframe_ms.median, result.keyframe_ms.p99);
    std::printf("  configured, keyframes without a loop by stage:");
    for (const auto& [stage, count] : result.configured.refused) {
      std::printf(" %s %zu", stage.c_str(), count);
    }
    std::printf("\n");
    for (const eval::DetectorPass& pass : result.sweep) printPass("sweep", pass);
    if (source.true_pose && source.protocol != eval::RunProtocol::kRobots) {
      printTrajectoryError(result, source.true_pose,
                           readPoseGraphConfig(arguments.get("--pose-graph-config")));
    }
    const std::string path = eval::writeDetectorReport(
        output_folder, label,
        source.description + "; config " + (config.empty() ? "defaults" : config), result);
    std::printf("results: %s\n", path.c_str());
  }
  return 0;
}

}  // namespace tools
}  // namespace landmark_loop_closure
