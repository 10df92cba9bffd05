#include "landmark_loop_closure/core/loop_detector.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "landmark_loop_closure/common/stopwatch.h"

namespace landmark_loop_closure {

const ParameterTable<AcceptanceOptions>& AcceptanceOptions::parameters() {
  using O = AcceptanceOptions;
  static const auto table =
      ParameterTable<O>("advanced/acceptance/", "precision first.")
          .number(
              "min_score", &O::min_score, between(0, 100),
              "final similarity a candidate needs (with sequence matching, the best path's mean): "
              "with max_false_alarms a floor under the calibrated decision, 0.1 (the loops it "
              "believes on Gardens Point and Nordland score 0.117 and up, bench/README.md); "
              "without it "
              "the whole decision, whose scale depends on advanced/descriptor/type, "
              "advanced/descriptor/condition_window and sequence_length: backbone with the window "
              "and "
              "L = 5, 0.34 (the highest wrong loop of Gardens Point's and Nordland's first "
              "halves scored 0.33); L = 1 with the window: 0.3; without the window "
              "(condition_window 0): 0.6. A descriptor that re-ranks is not calibrated: 0.25 "
              "for landmarks (the node sets it when it falls back to it); 0.7 for hog, 0.97 for "
              "calc (those three measured without the window, L = 1). At most 1, except with "
              "score_normalisation local_contrast or z_score (standard deviations).")
          .number("max_false_alarms", &O::max_false_alarms, between(0, 1000000),
                  "calibrated decision (a-contrario), 0 = off: a candidate that reached the "
                  "k-chain is believed only where fewer wrong places than this are expected to "
                  "score as high, from an exponential tail fitted to what the map's other places "
                  "(outside the candidate's place_window and the odometry's reach) scored against "
                  "the last 5 keyframes; the places counted are those the odometry does not rule "
                  "out, or, for a candidate that continues the last published loop (see "
                  "continue_across), the 2 * index_window + 1 places that would continue "
                  "it. A candidate of the query's own run must also stand out of what the places "
                  "just passed (exclude_recent_keyframes to twice that back) scored against the "
                  "last 200 keyframes, and the run must have left it (some keyframe between "
                  "scoring like an ordinary other place). A map of look-alike places needs more "
                  "than a varied route. 0.003: the largest of 0.001-0.03 without a wrong loop on "
                  "Nordland's first half played as one sequence (it transfers to Gardens Point; "
                  "bench/README.md). Off with a descriptor that re-ranks (min_score decides "
                  "alone).")
          .number("max_false_alarms_within_reach", &O::max_false_alarms_within_reach,
                  between(0, 1000000),
                  "max_false_alarms for a candidate that the odometry puts within its reach (a "
                  "place of the query's own session, odometry_gate on, mapping): the odometry "
                  "is a second witness besides appearance, so appearance may need less. 0 = "
                  "max_false_alarms for these too. 0.3: the largest of 0.1, 0.3, 1 without a "
                  "wrong loop on Gardens Point's first halves played as one robot run and the "
                  "generated aliasing corridor (1 publishes 3 wrong loops there; "
                  "bench/README.md).")
          .integer("consistent_keyframes", &O::consistent_keyframes, between(1, 100),
                   "k: consecutive keyframes that must match the same stretch of the map.")
          .integer("index_window", &O::index_window, between(0, 1000),
                   "their matches may differ by at most this many keyframe ids.")
          .integer("continue_across", &O::continue_across, between(1, 1000),
                   "keyframes after a published loop within which a candidate still continues "
                   "it: the next keyframe's with its match within index_window ids of that "
                   "loop's, a later one's (the keyframes between refused by a check: night, a "
                   "passing car) with its match not behind it and within index_window - 1 of "
                   "where the same pace puts it (one id a keyframe; as wide as index_window, "
                   "loops landed 3 frames off on Gardens Point's first halves). The calibrated "
                   "decision then counts only the 2 * index_window + 1 places that would "
                   "continue it, and the appearance check asks continuing_min_inliers cells. 1 = "
                   "the next keyframe only (before 2026-12-07). 10: 1 to 10 published no wrong "
                   "loop on the first halves of Gardens Point (every pair and protocol), 1 to 50 "
                   "none on Nordland's and the aliasing corridor; the gains level off by 10 "
                   "(bench/history.md).")
          .number("min_place_ratio", &O::min_place_ratio, between(0, 100),
                  "a candidate's score over the best score of another place in the shortlist "
                  "must reach this (a place-level ratio test; 0 = off): where the query looks "
                  "about as much like several places (forest, corridor, darkness), the best is a "
                  "guess and refused as \"ambiguous\". Another place: same session, more than "
                  "place_window ids away and, with the odometry gate on, beyond the odometry's "
                  "drift of it (laps of one run are one place); other sessions are not compared. "
                  "Chosen on the first halves of Gardens Point and Nordland (bench/README.md).")
          .integer("place_window", &O::place_window, between(0, 1000000),
                   "candidates within this many keyframe ids of each other are one place.")
          .group(&O::sequence, SequenceMatchingOptions::parameters());
  return table;
}

const ParameterTable<AcceptanceOptions>& AcceptanceOptions::evaluationParameters() {
  using O = AcceptanceOptions;
  static const auto table =
      ParameterTable<O>("acceptance/", "")
          .choice("consistency_unit", &O::consistency_unit, consistencyUnitNames(),
                  "how a place must stay matched before a loop is believed: \"keyframes\": "
                  "consistent_keyframes keyframes in a row, matches within index_window ids; "
                  "\"metres\": the robot travels consistent_distance_m while its matches stay "
                  "within match_window_m (plus its own step) along the old path - independent of "
                  "keyframe spacing and of dropped keyframes.")
          .number("consistent_distance_m", &O::consistent_distance_m, atLeast(0),
                  "metres: query travel over which the place must stay matched.")
          .number("match_window_m", &O::match_window_m, atLeast(0),
                  "metres: consecutive matches agree within this plus the query's step.")
          .choice(
              "score_normalisation", &O::score_normalisation, scoreNormalisationNames(),
              "what a candidate's similarity is normalised by before min_score, i.e. what "
              "the query resembles anyway: \"none\"; "
              "\"previous_keyframe\" (DBoW2): over its similarity to the keyframe before "
              "it, capped at 1; \"local_contrast\" (SeqSLAM): standardised against the "
              "query's similarities to the candidate's contrast_window neighbours on each side "
              "in the map; \"z_score\": standardised against its similarities to the map "
              "(at most 2000 keyframes spread over it; with sequence matching each path step "
              "is standardised by its own query keyframe's similarities, and the path's mean "
              "is compared). The middle two need sequence_length 1; none works with a descriptor "
              "that re-ranks (landmarks, backbone rerank_weight > 0). The last two are in standard "
              "deviations: set "
              "min_score to match. Measured against each other in bench/README.md.")
          .integer("contrast_window", &O::contrast_window, between(1, 1000),
                   "local_contrast: map keyframes on each side of a candidate it is compared "
                   "with.");
  return table;
}

std::string AcceptanceOptions::validate() const {
  std::string problems =
      parameters().check(*this) + evaluationParameters().check(*this) + sequence.validate();
  if (score_normalisation != ScoreNormalisation::kNone &&
      score_normalisation != ScoreNormalisation::kZScore && sequence.enabled()) {
    problems +=
        "advanced/acceptance/score_normalisation previous_keyframe and local_contrast apply to "
        "single "
        "keyframes' scores: they need advanced/acceptance/sequence_length 1 (z_score works with "
        "both)\n";
  }
  if (score_normalisation != ScoreNormalisation::kLocalContrast &&
      score_normalisation != ScoreNormalisation::kZScore && min_score > 1.0) {
    std::ostringstream problem;
    problem << "advanced/acceptance/min_score " << min_score
            << " is above 1, which no similarity reaches (only standardised scores, "
               "score_normalisation local_contrast or z_score, go above 1)\n";
    problems += problem.str();
  }
  return problems;
}

const std::vector<std::pair<std::string, DetectorMode>>& detectorModeNames() {
  static const std::vector<std::pair<std::string, DetectorMode>> names = {
      {"mapping", DetectorMode::kMapping}, {"localization", DetectorMode::kLocalization}};
  return names;
}

const char* toString(DetectorMode mode) {
  return mode == DetectorMode::kMapping ? "mapping" : "localization";
}

const ParameterTable<LoopDetectorOptions>& LoopDetectorOptions::modeParameter() {
  using O = LoopDetectorOptions;
  static const auto table = ParameterTable<O>("", "").choice(
      "mode", &O::mode, detectorModeNames(),
      "are you building a map or revisiting one? \"mapping\": search every keyframe and store "
      "it. \"localization\": search only, store nothing, no odometry gate (this run's odometry "
      "shares no frame with the map's); for revisiting a map loaded from database_path.");
  return table;
}

const ParameterTable<LoopDetectorOptions>& LoopDetectorOptions::mountParameters() {
  using O = LoopDetectorOptions;
  static const auto table =
      ParameterTable<O>("", "").group(&O::camera_mount, CameraMount::parameters());
  return table;
}

const ParameterTable<LoopDetectorOptions>& LoopDetectorOptions::parameters() {
  using O = LoopDetectorOptions;
  static const auto table =
      ParameterTable<O>("", "")
          .group(&O::input, InputLimits::parameters())
          .group(&O::keyframe, KeyframeSelectorOptions::parameters())
          .group(&O::descriptor, DescriptorOptions::parameters())
          .flag("advanced/descriptor/keep_thumbnails", &O::keep_thumbnails,
                "keep a 160x120 grey copy per keyframe (WebP, ~2 KB) for ~match_image and the "
                "appearance check (advanced/verification/appearance), which cannot run without "
                "it.")
          .group(&O::database, DatabaseOptions::parameters())
          .group(&O::acceptance, AcceptanceOptions::parameters())
          .group(&O::odometry_gate, OdometryGateOptions::parameters())
          .group(&O::verification, VerificationOptions::parameters())
          .group(&O::appearance, AppearanceCheckOptions::parameters())
          .group(&O::metric_pose, MetricPoseOptions::parameters())
          .integer("advanced/metric_pose/triangulation_keyframes", &O::triangulation_keyframes,
                   between(1, 20), "previous keyframes used; farther ones add baseline.");
  return table;
}

std::string LoopDetectorOptions::validate() const {
  std::ostringstream errors;
  errors << parameters().check(*this) << InputLimits::parameters().check(input);
  if (input.max_image_pixels <
      static_cast<long long>(input.min_image_side) * input.min_image_side) {
    errors << "advanced/input/max_image_pixels (" << input.max_image_pixels
           << ") is smaller than a minimum-size image\n";
  }
  errors << keyframe.validate() << descriptor.validate() << database.validate()
         << acceptance.validate() << odometry_gate.validate() << verification.validate()
         << appearance.validate() << metric_pose.validate() << camera_mount.validate();
  if (acceptance.max_false_alarms > 0.0 && descriptor.reranks() &&
      acceptance.min_score < kLandmarksMinScore) {
    // The calibrated decision is off for it: min_score alone decides, and a floor is no decision.
    errors << "advanced/acceptance/min_score " << acceptance.min_score
           << " decides alone for advanced/descriptor/type " << descriptor.type
           << ", which re-ranks its shortlist (the calibrated decision, max_false_alarms, does not "
              "apply to a re-ranked score): set it to that descriptor's threshold (landmarks "
           << kLandmarksMinScore << ")\n";
  }
  if (acceptance.score_normalisation != ScoreNormalisation::kNone && descriptor.reranks()) {
    // Its population is the query's global similarities to the map; a re-ranked score is
    // another measure, and re-ranking the whole map would cost what the shortlist saves.
    errors << "advanced/acceptance/score_normalisation " << toString(acceptance.score_normalisation)
           << " normalises global similarities: advanced/descriptor/type " << descriptor.type
           << " re-ranks its shortlist with another score (use \"none\")\n";
  }
  return errors.str();
}

const char* toString(CandidateVerdict verdict) {
  switch (verdict) {
    case CandidateVerdict::kAccepted:
      return "accepted";
    case CandidateVerdict::kBelowThreshold:
      return "below_threshold";
    case CandidateVerdict::kAwaitingConsistency:
      return "awaiting_consistency";
    case CandidateVerdict::kOutscored:
      return "outscored";
    case CandidateVerdict::kOdometryRejected:
      return "odometry_rejected";
    case CandidateVerdict::kGeometryRejected:
      return "geometry_rejected";
    case CandidateVerdict::kUnreadable:
      return "unreadable";
    case CandidateVerdict::kAmbiguous:
      return "ambiguous";
  }
  return "unknown";
}

namespace {

MapSession::Settings mapSettings(const LoopDetectorOptions& options,
                                 const DescriptorExtractor* extractor,
                                 const std::string& descriptor_identity) {
  MapSession::Settings settings;
  settings.database = options.database;
  settings.global_dimension = extractor ? extractor->globalDimension() : 1;
  settings.descriptor_identity = descriptor_identity;
  // The newest keyframes (triangulation, the consistency chain) and a few queries' candidates.
  settings.cached_records =
      static_cast<size_t>(4 * options.database.top_k + options.triangulation_keyframes +
                          options.acceptance.sequence.length) +
      16;
  return settings;
}

}  // namespace

LoopDetector::LoopDetector(const LoopDetectorOptions& options,
                           std::shared_ptr<const DescriptorExtractor> extractor)
    : options_(options),
      admission_(options.input, options.keyframe),
      describer_(std::move(extractor), options.descriptor),
      map_(mapSettings(options, describer_.extractorPointer(), describer_.identity()), this),
      consistency_(options.acceptance.consistency_unit,
                   options.acceptance.consistency_unit == ConsistencyUnit::kKeyframes
                       ? static_cast<double>(options.acceptance.index_window)
                       : options.acceptance.match_window_m),
      sequence_(options.acceptance.sequence),
      decision_(options),
      verifier_(options.verification),
      camera_mount_(options.camera_mount.toPose()) {
  const std::string problems = options.validate();
  if (!problems.empty()) throw std::invalid_argument(problems);
  if (!describer_.hasExtractor()) throw std::invalid_argument("a descriptor extractor is required");
  mode_ = options.mode;
}

LoopDetector::~LoopDetector() {
  try {
    KeyframeResult unreported;
    storeWarmedUp(&unreported);
  } catch (...) {
    // A destructor must not throw; store() keeps what the disk refused in memory anyway.
  }
}

void LoopDetector::storeWarmedUp(KeyframeResult* result) {
  for (KeyframeRecord& keyframe : describer_.takeHeld()) store(std::move(keyframe), result);
}

void LoopDetector::storeHeldKeyframes() {
  KeyframeResult unreported;
  storeWarmedUp(&unreported);
}

void LoopDetector::mapReplaced(uint32_t first_session, std::optional<uint64_t> next_id) {
  sessions_.restartAt(first_session);
  if (next_id) admission_.raiseNextId(*next_id);
  consistency_.reset();
  sequence_.reset();
  decision_.reset();
}

bool LoopDetector::store(KeyframeRecord keyframe, KeyframeResult* result) {
  StoredKeyframe outcome = map_.store(std::move(keyframe));
  result->stored = result->stored || outcome.stored;
  result->written_not_searched = result->written_not_searched || outcome.written_not_searched;
  if (!outcome.store_error.empty()) result->store_error = std::move(outcome.store_error);
  if (!outcome.map_damage.empty()) result->map_damage = std::move(outcome.map_damage);
  return outcome.stored;
}

void LoopDetector::reserveId(uint64_t id, KeyframeResult* result) {
  if (std::string error = map_.reserveId(id); !error.empty()) result->store_error = error;
}

void LoopDetector::setCameraMount(const std::optional<Pose>& mount) {
  camera_mount_ = mount ? std::optional<Pose>(normalisedPose(*mount)) : std::nullopt;
}

void LoopDetector::setMode(DetectorMode mode) {
  if (mode != mode_) {
    // Localising stores nothing: what mapping kept back goes in now.
    KeyframeResult unreported;
    storeWarmedUp(&unreported);
    // Chains and sequences of one mode say nothing in the other.
    consistency_.reset();
    sequence_.reset();
    decision_.reset();
  }
  mode_ = mode;
}

KeyframeResult LoopDetector::addKeyframe(uint64_t keyframe_id, double stamp, const Pose& pose,
                                         const cv::Mat& image, const CameraIntrinsics& intrinsics,
                                         const cv::Mat& depth, int64_t stamp_ns) {
  KeyframeResult result;
  result.keyframe_id = keyframe_id;
  if ((result.error = checkKeyframe(keyframe_id, image))) return result;
  sessions_.enter(keyframe_id);

  std::vector<float> raw_global;
  ImageDescriptor descriptor = describe(image, &result.times, &raw_global);
  const QueryResult query = search(keyframe_id, stamp, descriptor, &result);
  KeyframeRecord keyframe =
      makeKeyframe(keyframe_id, stamp, pose, image, intrinsics, depth, &result.times);
  keyframe.stamp_ns = stamp_ns != 0 ? stamp_ns : std::llround(stamp * 1e9);
  decide(&result, descriptor, query, keyframe, intrinsics);
  describer_.setPreviousGlobal(descriptor.global);
  if (result.loop) {
    result.loop->map_id = map_.mapId();
    result.loop->query_id = keyframe_id;
    result.loop->query_session = sessions_.current();
    result.loop->query_stamp = stamp;
    result.loop->query_pose = keyframe.pose;
  }
  bool kept = true;
  if (mode_ == DetectorMode::kLocalization) {
    // Published under the map's id but never stored: a later run must reuse neither its id nor
    // its session. Announced once the map holds that; never when it cannot be written.
    result.store_error = map_.reserveUnstored(keyframe.id, sessions_.current());
    kept = result.store_error.empty();
    if (kept) map_.announceUnstored(keyframe);
  } else {
    keyframe.descriptor = std::move(descriptor);
    if (describer_.warmingUp()) {
      reserveId(keyframe.id, &result);
      describer_.hold(std::move(keyframe), std::move(raw_global));
      result.stored = true;  // Kept, and stored once the window is full.
    } else {
      KeyframeResult warmed;
      storeWarmedUp(&warmed);
      if (!warmed.map_damage.empty()) result.map_damage = warmed.map_damage;
      if (!warmed.store_error.empty()) result.store_error = warmed.store_error;
      const bool over_budget_in_memory = map_.path().empty() && map_.overMemoryBudget();
      kept = store(std::move(keyframe), &result) || over_budget_in_memory;
    }
  }
  if (!kept && result.loop) {
    result.loop.reset();  // Its query keyframe is announced nowhere.
    result.loop_dropped = true;
  }
  return result;
}

std::optional<InputError> LoopDetector::checkKeyframe(uint64_t keyframe_id,
                                                      const cv::Mat& image) const {
  if (auto error = checkImage(image.cols, image.rows, image.type(), options_.input)) return error;
  if (auto error = checkTexture(image, options_.input)) return error;
  if (!database().empty() && keyframe_id <= database().summary(database().size() - 1).id) {
    return InputError{
        InputErrorCode::kStampNotIncreasing,
        "keyframe id " + std::to_string(keyframe_id) + " is not after the last stored keyframe"};
  }
  return std::nullopt;
}

ImageDescriptor LoopDetector::describe(const cv::Mat& image, StageTimes* times,
                                       std::vector<float>* raw_global) {
  const auto start = Clock::now();
  ImageDescriptor descriptor = describer_.describe(image, raw_global);
  if (options_.acceptance.sequence.enabled() || decision_.appliesTo(describer_.extractor())) {
    sequence_.push(descriptor);
  }
  times->describe_ms = millisecondsSince(start);
  return descriptor;
}

QueryResult LoopDetector::search(uint64_t keyframe_id, double stamp,
                                 const ImageDescriptor& descriptor, KeyframeResult* result) {
  const auto start = Clock::now();
  DatabaseOptions search = options_.database;
  // Localising: the map's last keyframes are not this run's recent past (the time rule stays).
  if (mode_ == DetectorMode::kLocalization) search.exclude_recent_keyframes = 0;
  QueryResult query;
  bool replayed = false;
  if (query_cache_) {
    const auto cached = query_cache_->find(keyframe_id);
    if (cached != query_cache_->end()) {
      query = cached->second;
      replayed = true;
    }
  }
  if (std::string damage = map_.takeNewDamage(); !damage.empty()) result->map_damage = damage;
  if (!replayed || !map_.damage().empty()) {
    query = map_.query(descriptor.global, stamp, search, sessions_.current());
    if (query_cache_ && !replayed && map_.damage().empty()) {
      query_cache_->emplace(keyframe_id, query);
    }
  }
  result->times.query_ms = millisecondsSince(start);
  result->query_status = query.status;
  return query;
}

KeyframeRecord LoopDetector::makeKeyframe(uint64_t keyframe_id, double stamp, const Pose& pose,
                                          const cv::Mat& image, const CameraIntrinsics& intrinsics,
                                          const cv::Mat& depth, StageTimes* times) {
  const auto features_start = Clock::now();
  KeyframeRecord keyframe;
  keyframe.id = keyframe_id;
  keyframe.session = sessions_.current();
  keyframe.stamp = stamp;
  keyframe.pose = normalisedPose(pose);
  if (options_.verification.enabled) {
    keyframe.local_features = verifier_.extractKeyframe(image, intrinsics);
    // A query's own depths are never used (PnP takes the match's); only stored keyframes need them.
    if (mode_ == DetectorMode::kMapping) {
      addDepths(keyframe.pose, depth, intrinsics, &keyframe.local_features);
    }
  }
  times->features_ms = millisecondsSince(features_start);
  keyframe.path = sessions_.advance(keyframe.pose);
  // Kept for ~match_image and compared by the appearance check.
  if (options_.keep_thumbnails) {
    keyframe.thumbnail = makeThumbnail(image);
  }
  return keyframe;
}

void LoopDetector::addDepths(const Pose& pose, const cv::Mat& depth,
                             const CameraIntrinsics& intrinsics, LocalFeatures* features) const {
  if (!intrinsics.valid() || features->empty()) return;
  if (!depth.empty()) {
    keypointsFromDepth(depth, intrinsics, options_.metric_pose, features);
    return;
  }
  if (!options_.metric_pose.triangulate_from_odometry || !camera_mount_) return;
  const Eigen::Isometry3d mount = camera_mount_->toIsometry();
  const Eigen::Isometry3d camera = pose.toIsometry() * mount;
  const size_t stored = database().size();
  for (size_t back = 1;
       back <= static_cast<size_t>(options_.triangulation_keyframes) && back <= stored; ++back) {
    const std::shared_ptr<const KeyframeRecord> neighbour = database().record(stored - back);
    // Another session's pose is in another odometry frame (a loaded map, the odometry before it
    // was re-initialised): no baseline to triangulate over.
    if (!neighbour || neighbour->local_features.empty() ||
        neighbour->session != sessions_.current())
      continue;
    const Eigen::Isometry3d neighbour_camera = neighbour->pose.toIsometry() * mount;
    triangulateKeypoints(neighbour->local_features, camera.inverse() * neighbour_camera, intrinsics,
                         options_.verification, options_.metric_pose, features);
  }
}

FrameResult LoopDetector::process(double stamp, const Pose& pose, const cv::Mat& image,
                                  const CameraIntrinsics& intrinsics, const cv::Mat& depth,
                                  const OdometrySince& odometry) {
  FrameResult result;
  result.admission = admit(stamp, pose, image.cols, image.rows, image.type(), odometry);
  if (result.admission.isKeyframe() &&
      (sessions_.takePending() || result.admission.selection.reanchored)) {
    markOdometryRestart(result.admission.keyframe_id);
  }
  if (result.admission.isKeyframe()) {
    result.keyframe =
        addKeyframe(result.admission.keyframe_id, stamp, pose, image, intrinsics, depth);
  }
  return result;
}

}  // namespace landmark_loop_closure
