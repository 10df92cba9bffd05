// lcd_evaluate --detector: the frames go through the LoopDetector the node runs, with a
// configuration file, and the loops it publishes are scored.
#pragma once

#include <functional>
#include <string>

#include "evaluate_support.h"
#include "landmark_loop_closure/eval/detector_evaluation.h"
#include "landmark_loop_closure/eval/match_verification.h"

namespace landmark_loop_closure {
namespace tools {

/// Frames for the detector: `play(colour, sink)` plays them (BGR images when `colour`).
struct DetectorSource {
  std::string description;  ///< How poses, stamps and truth were made; printed and saved.
  std::function<void(bool colour, const std::function<void(size_t, const eval::DetectorFrame&)>&)>
      play;
  eval::SamePlace same_place;
  /// Frames that start a later run (DetectorFrame::new_run, as eval::RunProtocol plays them).
  eval::RunProtocol protocol = eval::RunProtocol::kOneSequence;
  bool has_intrinsics = false;      ///< False: the geometric check is switched off (said so).
  bool has_odometry = false;        ///< False: the odometry gate is switched off (said so) ...
  bool gate_without_poses = false;  ///< ... unless the source made odometry up (ImageRuns).
  /// The true pose at a frame, where the source has one besides its odometry (the corridor, a
  /// bag with a truth topic): the keyframes' trajectory error is then reported.
  std::function<Pose(size_t frame)> true_pose;
  /// How far a loop (query frame, match frame) lands from the truth, in `offset_unit`: frames
  /// from the centre of the query's true place (image sequences), metres between the two true
  /// positions (sources with true poses); NaN where the query has no true place.
  std::function<double(size_t query, size_t match)> offset;
  std::string offset_unit = "frames";
  /// How far a loop may land and still be true, in offset_unit (printed beside the histogram).
  double offset_tolerance = 0.0;
};

/// Frames from `match` to the place of the run of consecutive true frames of `query` nearest to
/// it: the run's centre, or, for a run longer than 2 * `tolerance` + 1 frames (the vehicle stood
/// still), its frames more than `tolerance` from either end. NaN when the query has no true frame.
double framesFromTruth(const eval::GroundTruth& truth, size_t query, size_t match,
                       double tolerance);

/// The published loops by how far they land from the truth: one line, bins of one unit (frames)
/// or of half a unit (metres) up to the tolerance and one beyond, with the median and the largest.
std::string offsetHistogram(const std::vector<eval::PublishedLoop>& loops,
                            const DetectorSource& source);

/// How an image-only sequence of several runs (traversals) is played: as one sequence, or each
/// run with its own odometry (eval::RunProtocol).
struct ImageRuns {
  eval::RunProtocol protocol = eval::RunProtocol::kOneSequence;
  std::vector<size_t> starts;  ///< First image of each run after the first.
  /// kSessions: each step's heading changes by a normal error of this many radians per step
  /// (a random walk, seeded: every pass plays the same odometry), so the odometry drifts as a
  /// robot's does; the odometry gate is on.
  double heading_drift = 0.01;
};

/// An image sequence. Without poses: images 1 s apart, each 1 m further on a straight path
/// unless its grey image differs from the last moving one's by less than `still_threshold` grey
/// levels on average (standing still: no keyframe, as odometry would add none; 0 = every image
/// moves; `standing`, when given, says instead which frames stand), odometry gate off. With poses
/// and stamps (KITTI's, one per image): they drive the keyframe rule and the odometry gate as
/// odometry would. Valid `intrinsics` (of the camera at its own image size, scaled to the played
/// size) switch the geometric check on. `runs`: without poses, a later run's first image starts a
/// new run as its protocol says (with kSessions each run's odometry starts at the origin and
/// drifts, and the odometry gate is on).
DetectorSource imageSequenceSource(
    const std::vector<std::string>& paths, const eval::GroundTruth& truth,
    const std::vector<Pose>& poses = {}, const std::vector<double>& stamps = {},
    const CameraIntrinsics& intrinsics = {}, double still_threshold = 0.0, int image_width = 0,
    const std::vector<bool>& standing = {}, const ImageRuns& runs = {});

/// Frames at which two aligned traversals both stand still: frame i's grey picture (64 px wide)
/// differs from frame i - 1's by less than `threshold` grey levels on average in each traversal
/// (frame 0 never). For alignedGroundTruth's stops.
std::vector<bool> jointStops(const std::vector<std::string>& first,
                             const std::vector<std::string>& second, double threshold);

/// Which generated corridor, and how its laps meet.
struct CorridorRun {
  /// The aliasing corridor: bays that look alike (sim::CorridorWorld::Options::bay_length 4 m)
  /// seen through a wide lens (plumb_bob k1 -0.3, k2 0.1); the second lap in other light as
  /// always.
  bool aliasing = false;
  /// kSessions: the second lap is a new run whose odometry restarts at the origin;
  /// kLocalisation: the second lap localises in the first lap's map.
  eval::RunProtocol protocol = eval::RunProtocol::kOneSequence;
  /// Tracking lost: from this many laps on, the odometry is in another frame (40 m, -25 m and 90
  /// degrees away), which the detector must notice by itself (a new session). 0: never.
  double odometry_jump_at_laps = 0.0;
};

/// The generated corridor as the demo bag holds it: drifting odometry, intrinsics, and a loop is
/// true when the true positions lie within 2.5 m and 20 s apart (the demo report's rule).
DetectorSource corridorSource(double laps, const CorridorRun& run = {});

/// Every image of a bag with its odometry and camera_info (as the node receives them); a loop is
/// true when the truth topic's positions (else the odometry's) lie within `distance` metres and
/// `gap` seconds apart.
DetectorSource bagSource(const std::string& path, const std::string& image_topic,
                         const std::string& odom_topic, const std::string& truth_topic,
                         double distance, double gap);

/// The node's checks of a loop candidate in the node config at `config` (empty: the built-in
/// defaults, which equal config/default.yaml's): the appearance check, and ORB's geometric check
/// where `intrinsics` are valid.
eval::MatchChecks matchChecks(const std::string& config, const CameraIntrinsics& intrinsics);

/// Runs the detector over the source with --config (default: the built-in defaults, which equal
/// config/default.yaml) and each --descriptors entry (default: the config's descriptor); prints
/// and writes the results. Returns the exit status.
int runDetectorMode(const Arguments& arguments, const DetectorSource& source,
                    const std::string& dataset, const std::string& output_folder);

}  // namespace tools
}  // namespace landmark_loop_closure
