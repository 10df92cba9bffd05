#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/core/appearance_check.h"
#include "landmark_loop_closure/core/condition_standardiser.h"
#include "landmark_loop_closure/core/false_alarms.h"
#include "landmark_loop_closure/core/input_error.h"
#include "landmark_loop_closure/core/keyframe_selector.h"
#include "landmark_loop_closure/core/loop_detector_options.h"
#include "landmark_loop_closure/core/map_reading.h"
#include "landmark_loop_closure/core/odometry_gate.h"
#include "landmark_loop_closure/core/online_training.h"
#include "landmark_loop_closure/core/score_normalisation.h"
#include "landmark_loop_closure/core/sequence_matching.h"
#include "landmark_loop_closure/core/temporal_consistency.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/database/keyframe_store.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/geometry/metric_pose.h"

namespace landmark_loop_closure {

/// Outcome of the cheap first step for every frame.
struct FrameAdmission {
  std::optional<InputError> error;  ///< Set: refused, nothing changed.
  Selection selection{SelectionVerdict::kRedundant};
  uint64_t keyframe_id = 0;  ///< Id reserved for this frame when it is a keyframe.

  bool isKeyframe() const { return !error && selection.verdict == SelectionVerdict::kKeyframe; }
};

enum class CandidateVerdict {
  kAccepted,
  kBelowThreshold,       ///< score < min_score.
  kAwaitingConsistency,  ///< Above the threshold, fewer than k consistent keyframes so far.
  kOutscored,            ///< Consistent, but another candidate of this query scored higher.
  kOdometryRejected,     ///< Above the threshold, but the odometry cannot have drifted that far.
  kGeometryRejected,     ///< Consistent, but the geometric check refused it (see detail).
  kUnreadable,           ///< Its record could not be read from the map file (damaged).
  kAmbiguous,  ///< Above the threshold, but another place scored nearly as high (min_place_ratio).
};

const char* toString(CandidateVerdict verdict);

struct CandidateReport {
  uint64_t match_id = 0;
  double match_stamp = 0.0;
  double global_score = 0.0;  ///< Shortlist stage: cosine of the global descriptors.
  double score = 0.0;         ///< Final stage: the extractor's similarity, or the sequence's mean.
  double image_score = 0.0;   ///< This keyframe's own similarity (equals score without sequences).
  double place_ratio = 0.0;   ///< score over the best other place's (placeRatios).
  /// Non-loop places expected to score as high, over the map
  /// (advanced/acceptance/max_false_alarms); -1 when not tested.
  double false_alarms = -1.0;
  /// The places those were counted over: the map's that the odometry does not rule out, or the
  /// few that would continue the last keyframe's loop (0 when not tested).
  size_t false_alarm_places = 0;
  int consistent_keyframes = 0;
  CandidateVerdict verdict = CandidateVerdict::kBelowThreshold;
  std::string detail;  ///< Why, when the verdict alone does not say (gate numbers, geometry).
  int inliers = 0;     ///< Geometric inliers, when the check ran.
};

struct AcceptedLoop {
  uint64_t map_id = 0;  ///< The map both keyframes belong to (LoopDetector::mapId()).
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
  /// Online training (advanced/descriptor/broad/online_training_keyframes): keyframes held so far,
  /// 0 when not training. The keyframe that completes the set carries the training's summary (or
  /// why it failed) and the result of the last held keyframe, stored with all the others.
  int held_for_training = 0;
  std::string training_summary;
  /// Not committed to the map on disk (disk full, file gone): why. The keyframe is kept in
  /// memory (`stored`) unless search is past its memory budget.
  std::string store_error;
  /// On the first keyframe after the map's search rows failed their check (mapDamage()).
  std::string map_damage;
};

/// A keyframe safe to publish: committed to the map file (or kept where no file will hold it).
struct AnnouncedKeyframe {
  uint64_t map_id = 0;  ///< The map it is stored in (LoopDetector::mapId() when it was stored).
  KeyframeSummary summary;
};

struct FrameResult {
  FrameAdmission admission;
  std::optional<KeyframeResult> keyframe;  ///< Present when the frame was a keyframe.
};

/// Keyframe selection, description, database search and loop acceptance.
///
/// Threading: admit() is cheap and meant for the thread that receives frames; addKeyframe() does
/// the heavy work and is meant for one worker thread. They touch disjoint state, so one thread
/// may call admit() while another runs addKeyframe(). process() does both, for offline use.
class LoopDetector {
 public:
  /// Throws std::invalid_argument when options.validate() reports problems. `extractor` may be
  /// null only when needsOnlineTraining(options.descriptor): the detector then trains it.
  LoopDetector(const LoopDetectorOptions& options,
               std::shared_ptr<const DescriptorExtractor> extractor);
  /// Stores the keyframes still waiting for the condition window (see storeWarmedUp()).
  ~LoopDetector();
  LoopDetector(const LoopDetector&) = delete;
  LoopDetector& operator=(const LoopDetector&) = delete;

  /// Validates stamp, pose and image shape, then applies the keyframe rule.
  FrameAdmission admit(double stamp, const Pose& pose, int image_width, int image_height,
                       int image_cv_type);

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
                      const CameraIntrinsics& intrinsics = {}, const cv::Mat& depth = {});

  /// Worker thread: the camera's pose on the odometry's body frame, as it becomes known (tf); until
  /// then (nullopt) keypoint depths are not triangulated from the odometry. Starts as
  /// options.camera_mount.
  void setCameraMount(const std::optional<Pose>& mount);
  const std::optional<Pose>& cameraMount() const { return camera_mount_; }

  /// Worker thread: the map at `path` (a KeyframeStore, created when missing) becomes the
  /// database: its keyframes are loaded as earlier sessions (new keyframes get the next session
  /// number and ids after every loaded one, chains and the path start again, and the odometry
  /// gate leaves loops into earlier sessions alone, their odometry frame being another), and
  /// every keyframe stored from now on is committed to it when it is added. Past
  /// advanced/database/memory_budget_mb only the map's first keyframes are searched
  /// (mapKeyframesNotSearched()); the rows are checked beside search (mapDamage()). On refusal
  /// returns why and changes nothing; "" on success. Call it before frames are admitted: ids
  /// already handed out below the loaded ones are refused. While online training holds keyframes
  /// the map is opened when training ends (its result's store_error says if that failed).
  std::string openMap(const std::string& path);
  /// Worker thread: what readMap() needs to read a map for this detector, so that it can run on
  /// another thread while the worker goes on (a load), its result swapped in by adoptMap().
  MapReadSettings mapReadSettings() const;
  /// Worker thread: `map` (readMap() with mapReadSettings()) becomes the database, as openMap()
  /// says. Refused ("" or why) when the descriptor changed since the settings were taken.
  std::string adoptMap(ReadMap map);
  /// The map openMap() was asked for while online training held keyframes, opened when training
  /// ends; empty when none waits.
  const std::string& mapWaitingForTraining() const { return pending_map_path_; }
  /// Online training: keyframes held so far and wanted; {0, 0} when not training.
  std::pair<int, int> trainingProgress() const {
    return training_ ? std::make_pair(training_->held(), training_->wanted())
                     : std::make_pair(0, 0);
  }
  /// Worker thread: keeps the search graph and summaries beside the open map for the next start
  /// (they change with every keyframe, so they are written at shutdown, not as keyframes come),
  /// after storing the keyframes still waiting for the condition window. Returns "" or why.
  std::string saveMapGraph();
  /// Worker thread: why search stopped, "" while it runs. openMap() starts search at once and
  /// checks the map's integrity (its pages, and the rows sealed at its last clean shutdown) on a
  /// thread of its own (seconds for a large map), holding new keyframes from the file until it
  /// passes; when the map turns out damaged, nothing is searched from then on (query_status
  /// kMapDamaged: no loop is published) and nothing more is written to it: keyframes are kept in
  /// memory only (a reset starts a new map beside it).
  const std::string& mapDamage() const { return map_damage_; }
  /// Worker thread: sets mapDamage() when the map's check has just failed and returns it, once
  /// ("" otherwise, and then the next keyframe's result does not carry it).
  std::string takeNewMapDamage();
  /// Worker thread: keyframes of the open map left out of search at open, past
  /// advanced/database/memory_budget_mb: the map's first keyframes that fit it are searched, or
  /// those its saved search graph covers when more (delete PATH-graph to have it built within the
  /// budget).
  size_t mapKeyframesNotSearched() const { return map_unsearched_; }
  /// Worker thread: "checked", "being checked" or "damaged" ("" without a map file).
  std::string mapCheck() const;
  /// Worker thread: keyframes of this run the open map file will not hold: the map was found
  /// damaged (those held during its check, and every one after) or a write failed (disk full).
  /// They are in memory only. 0 without a map file.
  size_t mapKeyframesNotWritten() const;
  /// Worker thread: keyframes the open map file holds, or will once its check passes.
  size_t mapKeyframesInFile() const;
  /// Whether the last openMap() found the map's saved search graph (else it was built).
  bool mapGraphReused() const { return map_graph_reused_; }
  /// Worker thread: the open map's search graph is being built in the background (search is
  /// exact until it is swapped in, at the first search after it is ready).
  bool mapGraphBuilding() const { return graph_build_ != nullptr; }
  /// Worker thread, tests and offline tools: waits for that graph and swaps it in.
  void awaitMapGraph() { adoptBuiltGraph(true); }
  /// Temporary files of an interrupted save that opening the map removed.
  const std::vector<std::string>& mapLeftoversRemoved() const { return map_leftovers_removed_; }
  /// What opening the map repaired (keyframes a power cut left without their search rows).
  const std::vector<std::string>& mapRepairs() const { return map_repairs_; }
  /// Worker thread: the open map's file, or "" when keyframes live in memory only.
  std::string mapPath() const { return store_ ? store_->path() : ""; }
  /// Worker thread: writes a copy of the keyframes to `path` as a map (atomically: the copy
  /// appears whole or not at all). The open map's own path: nothing to do, every keyframe is
  /// committed. Refused before anything is written (saveTargetProblem): the open map under
  /// another name, what is not a regular file, an existing file unless `overwrite` (then only a
  /// map, which is first kept aside under a unique name, given in `kept_as`). Returns "" or why.
  std::string saveDatabase(const std::string& path, bool overwrite = false,
                           std::string* kept_as = nullptr);
  /// Worker thread: saveDatabase() in steps, so that keyframes go on between them (the node's
  /// ~save_database): checks the target and keeps an existing map aside as saveDatabase() does,
  /// then copies nothing yet. Returns "" or why. Without a map file the keyframes are written
  /// at once.
  std::string beginSave(const std::string& path, bool overwrite, std::string* kept_as);
  /// Worker thread: copies up to `pages` more pages of the map (SQLite pages: 2 KB); true once the
  /// copy is ready for takeSave(). Throws std::runtime_error: the copy failed, or a load or reset
  /// replaced the map meanwhile (the copy is abandoned and removed).
  bool continueSave(int pages);
  /// Worker thread: the copy to finish (MapCopy::finish(): the rows file and the rename) on any
  /// thread; null when beginSave() wrote the map at once.
  std::unique_ptr<MapCopy> takeSave() { return std::move(save_); }
  /// Worker thread: openMap() on an existing file.
  std::string loadDatabase(const std::string& path);
  /// What reset() did with the open map's file.
  struct ResetOutcome {
    std::string kept_as;  ///< Where the earlier map was kept; empty without one.
    /// Empty when the earlier map was kept and a fresh one started at its path; otherwise why
    /// not (the keyframes are forgotten all the same, new ones are kept in memory only).
    std::string problem;
  };
  /// Worker thread: forgets every keyframe, chain and session. With a map open, its file is
  /// kept under a new name and a fresh map starts at its path.
  ResetOutcome reset();
  /// Receiving thread: forgets the last keyframe and image size, so that the next frame starts the
  /// keyframe rule afresh whatever its stamp (time jumped back). Pair it with reset().
  void restartAdmission();
  /// Receiving thread: stamp of the last admitted keyframe, if any.
  std::optional<double> lastKeyframeStamp() const;
  /// Worker thread, before addKeyframe(keyframe_id): the odometry was re-initialised before this
  /// keyframe (its admission's selection.reanchored), so its pose is in another odometry frame
  /// than the keyframes before it: it starts a new session, or the next keyframe does if this one
  /// never comes (process() marks them itself).
  void markOdometryRestart(uint64_t keyframe_id) { odometry_restarts_.insert(keyframe_id); }
  /// process() callers (offline replays): the odometry was re-initialised before the next frame
  /// (another run in its own odometry frame): the keyframe rule starts afresh and the next
  /// keyframe starts a new session.
  void restartOdometry() {
    restartAdmission();
    odometry_restart_pending_ = true;
  }
  /// The session new keyframes get: 0 for the first run, +1 after each map loaded and each time
  /// the odometry was re-initialised. Poses of one session share one odometry frame.
  uint32_t session() const { return session_; }
  /// Worker thread: the identity of the map keyframes are stored in (KeyframeStore::mapId, or one
  /// drawn for a map in memory only). Keyframe ids repeat between maps (a loaded map keeps its
  /// own); (mapId(), keyframe id) never does. A reset starts a map with a new identity.
  uint64_t mapId() const { return store_ ? store_->mapId() : memory_map_id_; }
  /// What a saved database must have been made with (extractor name and descriptorIdentity()).
  const std::string& descriptorIdentity() const { return descriptor_identity_; }

  /// Records kept in memory when search reads them from a map: the newest keyframes
  /// (triangulation, the consistency chain) and a few queries' candidates.
  size_t cachedRecords() const;
  /// Drops a save in steps whose map is about to be replaced; its next step says so.
  void abandonSave();
  /// Search holds advanced/database/memory_budget_mb: new keyframes are searched for loops and
  /// written to the map file, if one is open, but not added to search.
  bool overMemoryBudget() const;

  /// Worker thread: from now on, keyframes are collected for takeAnnounced() (off by default, so
  /// offline replays keep nothing extra).
  void announceKeyframes(bool on) { announcing_ = on; }
  /// Worker thread: the keyframes that became safe to publish since the last call, in id order.
  /// With a map file a keyframe is announced once it is committed to it (the standardisation's
  /// warm-up and the map's integrity check hold keyframes back; a crash before loses them
  /// unannounced), or once it is clear the file will not hold it (damaged map, write failed);
  /// without one, once stored in memory; localising, at once (its id is reserved in the map).
  /// Keyframes the check held are committed here when it has passed meanwhile.
  std::vector<AnnouncedKeyframe> takeAnnounced();
  /// Whether stored keyframe `id` still waits for the map file to commit it (not announced yet:
  /// a crash would lose it, and its id may be given again).
  bool awaitingCommit(uint64_t id) const;

  /// Worker thread: switches between building the map and only searching it.
  void setMode(DetectorMode mode);
  DetectorMode mode() const { return mode_; }

  const KeyframeDatabase& database() const { return database_; }
  /// Worker thread: the exact stamp (ns) of a stored keyframe, as its record keeps it (read from
  /// the map for a loaded one); nullopt when it is not in search or its record cannot be read.
  std::optional<int64_t> keyframeStampNs(uint64_t id) const;
  const LoopDetectorOptions& options() const { return options_; }
  /// Worker thread, offline replays: waits up to `seconds` for online training that has started
  /// in the background; true when it has finished (the next keyframe then stores every held one)
  /// or when there is none.
  bool waitForTraining(double seconds) const {
    return !training_ || !training_->started() || training_->waitUntilReady(seconds);
  }
  /// Offline replays of the same frames (lcd_evaluate's threshold sweep): search results by
  /// keyframe id, recorded when absent and reused when present. Valid only while every pass stores
  /// the same keyframes (mapping mode, no memory budget), which the caller ensures; null = off.
  using QueryCache = std::unordered_map<uint64_t, QueryResult>;
  void setQueryCache(std::shared_ptr<QueryCache> cache) { query_cache_ = std::move(cache); }

  /// Null while online training holds keyframes.
  const DescriptorExtractor* extractor() const { return extractor_.get(); }

 private:
  // addKeyframe's steps, in order.
  /// The image's shape and texture, and an id after every stored one.
  std::optional<InputError> checkKeyframe(uint64_t keyframe_id, const cv::Mat& image) const;
  /// The extractor's descriptor, its global vector standardised against the recent keyframes.
  /// `raw_global`: the global vector before standardisation.
  ImageDescriptor describe(const cv::Mat& image, StageTimes* times, std::vector<float>* raw_global);
  /// The database's candidates (or the replay cache's; none when the map is damaged).
  QueryResult search(uint64_t keyframe_id, double stamp, const ImageDescriptor& descriptor,
                     KeyframeResult* result);
  /// The keyframe as it will be stored, its descriptor aside: pose, path, keypoints with their
  /// depths, thumbnail.
  KeyframeRecord makeKeyframe(uint64_t keyframe_id, double stamp, const Pose& pose,
                              const cv::Mat& image, const CameraIntrinsics& intrinsics,
                              const cv::Mat& depth, StageTimes* times);
  /// Commits the keyframe to the map file and adds it to search (within the memory budget).
  void store(KeyframeRecord keyframe, KeyframeResult* result);
  /// Sets mapDamage() (and `result`'s, once) when the map's integrity check has failed.
  void noteMapDamage(KeyframeResult* result);
  /// `query_keyframe`: the keyframe being added (pose and path set, not yet stored).
  void decide(KeyframeResult* result, const ImageDescriptor& descriptor, const QueryResult& query,
              const KeyframeRecord& query_keyframe, const CameraIntrinsics& intrinsics);
  /// Sequence matching: replaces the reports by the sequence matcher's candidates and scores.
  /// False while the history is shorter than a sequence (every report then waits).
  /// Sets each report's place_ratio (placeRatios over the shortlist).
  void rateDistinctiveness(std::vector<CandidateReport>* reports) const;
  /// Whether advanced/acceptance/max_false_alarms applies: on, and the descriptor's final score is
  /// the global similarity the background is made of (no re-ranking).
  bool calibrates() const;
  /// advanced/acceptance/max_false_alarms: whether so few wrong places are expected to score as
  /// high as the report over the map (ScoreTail of the pooled backgrounds_) that it may be
  /// believed; sets its false_alarms, and its detail when not. A candidate among the places the
  /// query has just passed must also stand out of what those score (passed_places_), and one of the
  /// query's own run must have been left (leftThePlace) at the tail's threshold.
  bool passesFalseAlarms(CandidateReport* report, const KeyframeRecord& query_keyframe);
  /// Whether, between `match` and the query in the query's own run, some keyframe outside the
  /// match's place_window scores at most `level` as a candidate would (the query looked like an
  /// ordinary other place there): a revisit leaves the place and comes back, a slow stretch of
  /// look-alike frames never does. Says, in `detail`, the lowest score found when not.
  bool leftThePlace(const KeyframeSummary& match, double level, std::string* detail);
  /// Adds this keyframe's background to backgrounds_ and its passed places' scores to
  /// passed_places_ (when calibrates()).
  void recordBackground(const KeyframeRecord& query_keyframe);
  /// Whether `match` continues the loop the keyframe before `query_id` published (last_loop_).
  bool continuesLastLoop(const KeyframeSummary& match, uint64_t query_id) const;
  /// advanced/acceptance/max_false_alarms, or max_false_alarms_within_reach where the odometry puts
  /// the match within its reach.
  double falseAlarmBound(const KeyframeSummary* match, const KeyframeRecord& query_keyframe) const;
  /// Whether `match` is among the places the query has just passed (passed_places_).
  bool justPassed(const KeyframeSummary& match, uint64_t query_id) const;
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

  /// Online training: holds the keyframe; once enough are held, trains and adds them all.
  KeyframeResult holdForTraining(HeldKeyframe keyframe);
  /// Stores the keyframes that came while the condition window was warming up: described by the
  /// full window once it is full, as they were otherwise (a save, a map switch, a reset or the
  /// end before then).
  void storeWarmedUp(KeyframeResult* result);

  LoopDetectorOptions options_;
  std::shared_ptr<const DescriptorExtractor> extractor_;
  std::unique_ptr<OnlineBroadTraining> training_;
  GeometricVerifier verifier_;

  // Admission state (receiving thread).
  KeyframeSelector selector_;
  std::optional<cv::Size> image_size_;
  std::atomic<uint64_t> next_keyframe_id_{0};

  // Search state (worker thread).
  KeyframeDatabase database_;
  std::unique_ptr<KeyframeStore> store_;  ///< The map on disk; null: memory only.
  std::unique_ptr<MapCopy> save_;         ///< A save in steps (beginSave); before store_ dies.
  bool save_abandoned_ = false;           ///< The map was replaced during that save.
  std::string pending_map_path_;          ///< Opened once online training has made the descriptor.
  bool map_graph_reused_ = false;
  std::unique_ptr<BackgroundGraph> graph_build_;  ///< See mapGraphBuilding().
  /// Swaps the background graph in when it is ready (or, `wait`, once it is).
  void adoptBuiltGraph(bool wait);
  std::vector<std::string> map_leftovers_removed_;
  std::vector<std::string> map_repairs_;
  std::string map_damage_;
  size_t map_unsearched_ = 0;
  size_t map_unwritten_ = 0;  ///< Keyframes store() could not write (see mapKeyframesNotWritten).
  ConditionStandardiser standardiser_;
  /// A session's first keyframes, standardised against a window of fewer than condition_window
  /// keyframes: kept out of the database until the window is full (they are never candidates
  /// before: exclude_recent_keyframes), then described by its mean and stored.
  struct WarmingKeyframe {
    KeyframeRecord keyframe;
    std::vector<float> raw_global;
  };
  std::vector<WarmingKeyframe> warming_;
  /// announceKeyframes(): keyframes waiting for the map's check to commit them, and those ready.
  bool announcing_ = false;
  std::deque<AnnouncedKeyframe> waiting_for_commit_;
  std::vector<AnnouncedKeyframe> announced_;
  void announce(const KeyframeRecord& keyframe, bool wait_for_commit);
  /// Marks `id` published in the map before its keyframe is stored (KeyframeStore's reserve).
  void reserveId(uint64_t id, KeyframeResult* result);
  /// The last keyframe's global vector (score_normalisation previous_keyframe).
  std::vector<float> previous_global_;
  TemporalConsistency consistency_;
  SequenceMatcher sequence_;
  /// advanced/acceptance/max_false_alarms: what the last kPooledBackgrounds searched keyframes'
  /// wrong places scored (ids, sessions and scores), pooled for the tail: one keyframe's sample of
  /// a small map is too thin to fit, and the map's look-alikes change slowly along a path.
  struct PlaceScore {
    uint64_t id = 0;
    uint32_t session = 0;
    double score = 0.0;
  };
  static constexpr size_t kPooledBackgrounds = 5;
  std::deque<std::vector<PlaceScore>> backgrounds_;
  /// advanced/acceptance/max_false_alarms: places of the query's run from E + 1 to 2E keyframes
  /// back (E = exclude_recent_keyframes: as far beyond the exclusion as it reaches) are "just
  /// passed": their scores, pooled over queries, are the tail a candidate among them must stand
  /// out of.
  PassedPlaceScores passed_places_;
  /// advanced/acceptance/max_false_alarms: the loop the last keyframe published. A candidate of the
  /// next keyframe that continues it (within index_window of its match) is one of the few places
  /// that would continue it, not one of the whole map's.
  struct PublishedLoop {
    uint64_t query_id = 0;
    uint32_t query_session = 0;
    uint64_t match_id = 0;
    uint32_t match_session = 0;
  };
  std::optional<PublishedLoop> last_loop_;
  size_t background_places_ = 0;  ///< Eligible places of the newest background.
  std::shared_ptr<QueryCache> query_cache_;
  DetectorMode mode_ = DetectorMode::kMapping;
  uint32_t session_ = 0;
  std::set<uint64_t> odometry_restarts_;                 ///< Keyframe ids that start a new session.
  bool odometry_restart_pending_ = false;                ///< restartOdometry(), for process().
  uint64_t memory_map_id_ = KeyframeStore::drawMapId();  ///< mapId() without a map file.
  std::string descriptor_identity_;
  std::optional<Pose> camera_mount_;
  struct PathEnd {
    Pose pose;
    PathLength path;
    uint32_t session = 0;
  };
  std::optional<PathEnd> last_keyframe_;  ///< The last keyframe processed (stored or not).
};

}  // namespace landmark_loop_closure
