#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/core/appearance_check.h"
#include "landmark_loop_closure/core/calibrated_decision.h"
#include "landmark_loop_closure/core/candidate_report.h"
#include "landmark_loop_closure/core/input_error.h"
#include "landmark_loop_closure/core/keyframe_admission.h"
#include "landmark_loop_closure/core/keyframe_describer.h"
#include "landmark_loop_closure/core/keyframe_selector.h"
#include "landmark_loop_closure/core/loop_detector_options.h"
#include "landmark_loop_closure/core/map_session.h"
#include "landmark_loop_closure/core/odometry_gate.h"
#include "landmark_loop_closure/core/score_normalisation.h"
#include "landmark_loop_closure/core/sequence_matching.h"
#include "landmark_loop_closure/core/session_counter.h"
#include "landmark_loop_closure/core/temporal_consistency.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/geometry/metric_pose.h"

namespace landmark_loop_closure {

struct AcceptedLoop {
  uint64_t map_id = 0;  ///< The map both keyframes belong to (MapSession::mapId()).
  uint64_t query_id = 0;
  uint32_t query_session = 0;
  double query_stamp = 0.0;
  Pose query_pose;
  uint64_t match_id = 0;
  uint32_t match_session = 0;  ///< The run that stored the match (earlier ones come from a file).
  double match_stamp = 0.0;
  Pose match_pose;
  double global_score = 0.0;  ///< Cosine of the global descriptors (the shortlist's).
  /// The landmark re-ranking's similarity; global_score when the descriptor does not re-rank.
  double rerank_score = 0.0;
  /// What min_score was compared with: rerank_score, or the sequence mean, or normalised.
  double score = 0.0;
  int consistent_keyframes = 0;
  /// Set when the geometric check confirmed the place (it is absent when the check is off or no
  /// intrinsics were known and advanced/verification/required is false); its pose may be ambiguous.
  std::optional<VerificationResult> verification;
  /// Set when the ORB check could not confirm the place and the appearance check did (no
  /// relative pose then).
  std::optional<AppearanceCheckResult> appearance;
  /// Set when the match keyframe had keypoint depths and PnP ran (found or not, and why).
  std::optional<MetricPoseResult> metric_pose;
  /// The relative pose for a pose graph: the metric one when found, else the verified scale-free
  /// one when advanced/verification/publish_scale_free_pose is set; absent otherwise.
  std::optional<RelativePose> relative_pose;
  /// A loop into another robot's map (the fleet): that map, the odometry frame match_pose is in
  /// as the other robot names it, and where its camera sits on its base (absent: not known).
  /// match_map_id 0: a loop within map_id, the query's own mount at both ends.
  uint64_t match_map_id = 0;
  std::string match_odometry_frame;
  std::optional<Pose> match_camera_mount;
};

struct StageTimes {
  double describe_ms = 0.0;
  double query_ms = 0.0;
  double rerank_ms = 0.0;
  double features_ms = 0.0;  ///< Keypoints of the keyframe and their depths.
  double verify_ms = 0.0;    ///< The geometric check (and PnP) of the candidates that reached it.
  double totalMs() const { return describe_ms + query_ms + rerank_ms + features_ms + verify_ms; }
};

struct KeyframeResult {
  std::optional<InputError> error;  ///< Set: the keyframe was refused and not stored.
  uint64_t keyframe_id = 0;
  /// Kept: false when refused, localising, or past the memory budget without a map file.
  bool stored = false;
  /// Past advanced/database/memory_budget_mb with a map file: written to the map, not searched (a
  /// later start searches it when the budget leaves room for it).
  bool written_not_searched = false;
  QueryStatus query_status = QueryStatus::kDatabaseTooSmall;
  std::optional<AcceptedLoop> loop;         ///< The accepted loop, if any.
  std::vector<CandidateReport> candidates;  ///< Every candidate considered, best first.
  StageTimes times;
  /// The map on disk refused it (disk full, file gone, the map not checkable while the disk is
  /// full): why. Such a keyframe is not kept, not searched and never announced, and its loop is
  /// dropped (`loop_dropped`): no backend hears of a keyframe the map lacks. Localising, its id
  /// could not be reserved: the same.
  std::string store_error;
  /// The loop this keyframe found, dropped with it (store_error).
  bool loop_dropped = false;
  /// On the first keyframe after the map's search rows failed their check (MapSession::damage()).
  std::string map_damage;
};

struct FrameResult {
  FrameAdmission admission;
  std::optional<KeyframeResult> keyframe;  ///< Present when the frame was a keyframe.
};

/// Keyframe selection, description, database search and loop acceptance. The map searched, and
/// its file, are map()'s (MapSession): open, save and reset it there.
///
/// Threading: admission() (admit(), restartAdmission(), lastKeyframeStamp()) is cheap and meant
/// for the thread that receives frames; addKeyframe() does the heavy work and is meant for one
/// worker thread. They touch disjoint state (KeyframeAdmission), so one thread may admit while
/// another runs addKeyframe(). process() does both, for offline use. map() is the worker's.
class LoopDetector : private MapUser {
 public:
  /// Throws std::invalid_argument when options.validate() reports problems or `extractor` is null.
  LoopDetector(const LoopDetectorOptions& options,
               std::shared_ptr<const DescriptorExtractor> extractor);
  /// Stores the keyframes still waiting for the condition window (see storeWarmedUp()).
  ~LoopDetector();
  LoopDetector(const LoopDetector&) = delete;
  LoopDetector& operator=(const LoopDetector&) = delete;

  /// KeyframeAdmission::admit.
  FrameAdmission admit(double stamp, const Pose& pose, int image_width, int image_height,
                       int image_cv_type, const OdometrySince& odometry = nullptr) {
    return admission_.admit(stamp, pose, image_width, image_height, image_cv_type, odometry);
  }
  /// The receiving thread's part, reachable without the worker's lock.
  KeyframeAdmission& admission() { return admission_; }

  /// Describes an admitted keyframe, searches the database, decides on a loop and stores it.
  /// `image` may be grey, BGR or BGRA, 8 or 16 bit; `intrinsics` are those of `image` (invalid
  /// ones: loops are not verified, or refused when advanced/verification/required).
  /// `depth`: optional depth image registered to `image` (16-bit or float, see MetricPoseOptions);
  /// without one, keypoint depths are triangulated from the odometry when enabled.
  /// `stamp_ns`: the image's stamp exactly (ns since the epoch) as the map keeps it; 0: `stamp`
  /// rounded to the nanosecond.
  KeyframeResult addKeyframe(uint64_t keyframe_id, double stamp, const Pose& pose,
                             const cv::Mat& image, const CameraIntrinsics& intrinsics = {},
                             const cv::Mat& depth = {}, int64_t stamp_ns = 0);

  FrameResult process(double stamp, const Pose& pose, const cv::Mat& image,
                      const CameraIntrinsics& intrinsics = {}, const cv::Mat& depth = {},
                      const OdometrySince& odometry = nullptr);

  /// The camera's pose on the odometry's body frame, as it becomes known (tf); until then
  /// (nullopt) keypoint depths are not triangulated from the odometry. Starts as
  /// options.camera_mount. With the detector held, as every reader holds it: the node looks the
  /// mount up while preparing a keyframe and DetectorRuntime sets it under its lock
  /// (PreparedKeyframe::camera_mount); before the runtime starts, any thread.
  void setCameraMount(const std::optional<Pose>& mount);
  const std::optional<Pose>& cameraMount() const { return camera_mount_; }

  /// Worker thread: the map searched and kept (open, save, reset, damage).
  MapSession& map() { return map_; }
  const MapSession& map() const { return map_; }
  /// The keyframes searched: map().database().
  const KeyframeDatabase& database() const { return map_.database(); }

  /// Receiving thread: KeyframeAdmission::restart. Pair it with map().reset().
  void restartAdmission() { admission_.restart(); }
  /// Receiving thread: stamp of the last admitted keyframe, if any.
  std::optional<double> lastKeyframeStamp() const { return admission_.lastKeyframeStamp(); }
  /// Worker thread, before addKeyframe(keyframe_id): the odometry was re-initialised before this
  /// keyframe (its admission's selection.reanchored), so its pose is in another odometry frame
  /// than the keyframes before it: it starts a new session, or the next keyframe does if this one
  /// never comes (process() marks them itself).
  void markOdometryRestart(uint64_t keyframe_id) { sessions_.markRestart(keyframe_id); }
  /// process() callers (offline replays): the odometry was re-initialised before the next frame
  /// (another run in its own odometry frame): the keyframe rule starts afresh and the next
  /// keyframe starts a new session.
  void restartOdometry() {
    restartAdmission();
    sessions_.markPending();
  }
  /// The session new keyframes get: 0 for the first run, +1 after each map loaded and each time
  /// the odometry was re-initialised. Poses of one session share one odometry frame.
  uint32_t session() const { return sessions_.current(); }
  /// What a saved database must have been made with (extractor name and descriptorIdentity()).
  const std::string& descriptorIdentity() const { return describer_.identity(); }

  /// Worker thread: switches between building the map and only searching it.
  void setMode(DetectorMode mode);
  DetectorMode mode() const { return mode_; }

  const LoopDetectorOptions& options() const { return options_; }
  /// Offline replays of the same frames (lcd_evaluate's threshold sweep): search results by
  /// keyframe id, recorded when absent and reused when present. Valid only while every pass stores
  /// the same keyframes (mapping mode, no memory budget), which the caller ensures; null = off.
  using QueryCache = std::unordered_map<uint64_t, QueryResult>;
  void setQueryCache(std::shared_ptr<QueryCache> cache) { query_cache_ = std::move(cache); }

  const DescriptorExtractor* extractor() const { return describer_.extractorPointer(); }

 private:
  // addKeyframe's steps, in order.
  /// The image's shape and texture, and an id after every stored one.
  std::optional<InputError> checkKeyframe(uint64_t keyframe_id, const cv::Mat& image) const;
  /// The extractor's descriptor, its global vector standardised against the recent keyframes.
  /// `raw_global`: the global vector before standardisation.
  ImageDescriptor describe(const cv::Mat& image, StageTimes* times, std::vector<float>* raw_global);
  /// The map's candidates (or the replay cache's; none when the map is damaged).
  QueryResult search(uint64_t keyframe_id, double stamp, const ImageDescriptor& descriptor,
                     KeyframeResult* result);
  /// The keyframe as it will be stored, its descriptor aside: pose, path, keypoints with their
  /// depths, thumbnail.
  KeyframeRecord makeKeyframe(uint64_t keyframe_id, double stamp, const Pose& pose,
                              const cv::Mat& image, const CameraIntrinsics& intrinsics,
                              const cv::Mat& depth, StageTimes* times);
  /// map_.store(), its outcome told in `result`; whether the keyframe was stored.
  bool store(KeyframeRecord keyframe, KeyframeResult* result);
  /// `query_keyframe`: the keyframe being added (pose and path set, not yet stored).
  void decide(KeyframeResult* result, const ImageDescriptor& descriptor, const QueryResult& query,
              const KeyframeRecord& query_keyframe, const CameraIntrinsics& intrinsics);
  /// Sets each report's place_ratio (placeRatios over the shortlist).
  void rateDistinctiveness(std::vector<CandidateReport>* reports) const;
  /// What the calibrated decision is lent for this keyframe.
  DecisionContext decisionContext() {
    return DecisionContext{database(), describer_.extractor(), sequence_, mode_,
                           sessions_.current()};
  }
  /// The first of `leaders` (best-scoring candidates of their places, in score order) whose place
  /// (place_window ids, same session) the report's match is in; null when it leads its own.
  const CandidateReport* placeLeader(const CandidateReport& report,
                                     const std::vector<const CandidateReport*>& leaders) const;
  /// Whether the report's match is within index_window ids of its place's leader.
  bool nearLeader(const CandidateReport& report, const CandidateReport& leader) const;
  /// advanced/acceptance/score_normalisation: each report's score normalised by what the query
  /// resembles anyway (score_normalisation.h); `indices` are the reports' database indices. With
  /// sequence matching (z_score only) the sequence matcher is told the query's standardisation
  /// instead.
  void normaliseScores(std::vector<CandidateReport>* reports, const ImageDescriptor& descriptor,
                       const std::vector<size_t>& indices, double stamp);
  /// Sequence matching: replaces the reports by the sequence matcher's candidates and scores.
  /// False while the history is shorter than a sequence (every report then waits).
  bool scoreSequences(std::vector<CandidateReport>* reports, const ImageDescriptor& descriptor,
                      const std::vector<size_t>& indices, double stamp);
  /// Whether a chain is long enough to believe; when not, says how far it got (metres).
  bool consistentLongEnough(const TemporalConsistency::Chain& chain, std::string* detail) const;
  /// False when the candidate must be refused; fills report and, when verified, loop. The ORB
  /// check first; where it cannot confirm the place, the appearance check of the two thumbnails
  /// (`query_cells`: the query's, computed on first use).
  bool verify(const KeyframeRecord& query, const KeyframeRecord& match,
              const CameraIntrinsics& intrinsics, CandidateReport* report, AcceptedLoop* loop,
              std::optional<CellFeatures>* query_cells);
  /// The appearance check's cells of a keyframe's thumbnail; empty when it has none or the
  /// descriptor has no feature maps.
  CellFeatures thumbnailCells(const KeyframeRecord& keyframe) const;
  /// Depths for the new keyframe's keypoints: from `depth`, else triangulated against the last
  /// stored keyframes with the odometry's motion.
  void addDepths(const Pose& pose, const cv::Mat& depth, const CameraIntrinsics& intrinsics,
                 LocalFeatures* features) const;

  /// Stores the keyframes that came while the condition window was warming up: described by the
  /// full window once it is full, as they were otherwise (a save, a map switch, a reset or the
  /// end before then).
  void storeWarmedUp(KeyframeResult* result);
  // MapUser: the map asks for the warm-up's keyframes before it is saved or replaced, and says
  // when another map is searched (chains, sessions and ids start again).
  void storeHeldKeyframes() override;
  void mapReplaced(uint32_t first_session, std::optional<uint64_t> next_id) override;
  /// map_.reserveId(), a failure told in `result`.
  void reserveId(uint64_t id, KeyframeResult* result);

  LoopDetectorOptions options_;
  KeyframeAdmission admission_;  ///< The receiving thread's.
  // The worker's stages, in the order addKeyframe() runs them.
  KeyframeDescriber describer_;  ///< Before map_: the map is opened for its identity.
  MapSession map_;
  std::shared_ptr<QueryCache> query_cache_;
  TemporalConsistency consistency_;
  SequenceMatcher sequence_;
  CalibratedDecision decision_;
  GeometricVerifier verifier_;
  std::optional<Pose> camera_mount_;  ///< For keypoint depths triangulated from the odometry.
  DetectorMode mode_ = DetectorMode::kMapping;
  SessionCounter sessions_;
};

}  // namespace landmark_loop_closure
