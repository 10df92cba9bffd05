// Other robots' rows kept as maps of their own, searched for each own keyframe, chained over
// consecutive keyframes, and a fetched candidate checked as the detector checks its own loops.
#include "landmark_loop_closure/fleet/fleet_matcher.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "landmark_loop_closure/common/text_and_files.h"
#include "landmark_loop_closure/core/false_alarms.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/core/sequence_matching.h"

namespace landmark_loop_closure {

namespace {

/// Chain ids of two maps never come within a place window of each other.
constexpr int kMapIdBits = 40;
/// Longest odometry frame name a row may carry.
constexpr size_t kMaxFrameNameBytes = 256;
/// A robot's two keyframes of one session this close by its odometry are one place (the true
/// loop rule's radius).
constexpr double kSamePlaceMetres = 2.5;

/// Longest robot name a row may carry (it is named in log lines and diagnostics).
constexpr size_t kMaxRobotNameBytes = 64;

std::string robotNameProblem(const std::string& name) {
  if (name.empty()) return "no robot name";
  if (name.size() > kMaxRobotNameBytes) {
    return "a robot name of " + std::to_string(name.size()) + " bytes (at most " +
           std::to_string(kMaxRobotNameBytes) + ")";
  }
  for (const char c : name) {
    if (c < 0x20 || c > 0x7e) return "a robot name with characters other than printable ASCII";
  }
  return "";
}

std::string seconds(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.0f s", value);
  return text;
}

}  // namespace

FleetMatcher::FleetMatcher(FleetOptions options, const std::string& descriptor_identity,
                           int dimension)
    : options_(std::move(options)),
      fingerprint_(descriptorFingerprint(descriptor_identity)),
      identity_(descriptor_identity),
      dimension_(dimension) {
  SequenceMatchingOptions sequence;
  sequence.length = options_.sequence_length;
  speeds_ = sequence.enabled() ? sequence.speeds() : std::vector<double>{1.0};
}

std::string FleetMatcher::addRow(const SharedKeyframe& row, double now_s, uint64_t own_map_id) {
  return addRowFrom(row.robot, row, now_s, own_map_id).line;
}

RowVerdict FleetMatcher::addRowFrom(const std::string& peer, const SharedKeyframe& row,
                                    double now_s, uint64_t own_map_id) {
  RowVerdict verdict;
  // Everything the row says is checked before it touches any state; only the peer (a
  // subscription this detector chose) keys what is kept.
  std::string reason, why;
  if (row.map_id == own_map_id) {
    reason = "own map";
    why = "it names this detector's own map (is this detector among its own fleet/peers?)";
  } else if (const std::string problem = robotNameProblem(row.robot); !problem.empty()) {
    reason = "robot name";
    why = problem;
  } else if (row.id >= (uint64_t{1} << kMapIdBits)) {
    reason = "id range";
    why = "its id is 2^" + std::to_string(kMapIdBits) + " or more";
  } else if (row.odometry_frame.size() > kMaxFrameNameBytes) {
    reason = "frame name";
    why = "an odometry frame name of " + std::to_string(row.odometry_frame.size()) +
          " bytes (at most " + std::to_string(kMaxFrameNameBytes) + ")";
  } else if (row.descriptor_fingerprint != fingerprint_) {
    reason = "descriptor";
    why = "it was described by another descriptor (fingerprint " +
          std::to_string(row.descriptor_fingerprint) + ", this detector's " +
          std::to_string(fingerprint_) + " is " + identity_ +
          "): both robots need the same descriptor settings and model";
  } else if (const std::string problem = row.problem(dimension_); !problem.empty()) {
    reason = "malformed";
    why = problem;
  }
  FleetRobot& robot = robots_[peer];
  robot.peer = peer;
  std::string back;
  if (robot.silent) {
    back = "peer " + peer + " is heard again after " + seconds(now_s - robot.last_heard_s) +
           "; its " + std::to_string(robot.rows) + " keyframes were kept";
    robot.silent = false;
  }
  robot.last_heard_s = now_s;
  if (reason.empty() && !robot.robot.empty() && row.robot != robot.robot) {
    reason = "robot name";
    why = "it names robot '" + row.robot + "' where this peer's first row named '" + robot.robot +
          "'";
  }
  const auto held = maps_.find(row.map_id);
  if (reason.empty() && held != maps_.end() && held->second.peer() != peer) {
    reason = "map of another peer";
    why = "map " + std::to_string(row.map_id) + " was shared first by peer " + held->second.peer();
  }
  const bool new_map = held == maps_.end() && robot.map_ids.count(row.map_id) == 0;
  if (reason.empty() && new_map &&
      robot.map_ids.size() >= static_cast<size_t>(options_.max_maps_per_robot)) {
    reason = "maps bound";
    why = "it starts map " + std::to_string(robot.map_ids.size() + 1) +
          " of this peer, past advanced/fleet/max_maps_per_robot";
  }
  if (!reason.empty()) {
    ++robot.rows_refused;
    ++robot.refusals[reason];  // The caller throttles the line by peer and reason.
    verdict.line = (back.empty() ? "" : back + "; ") + "a shared keyframe from peer " + peer +
                   " (map " + std::to_string(row.map_id) + ", id " + std::to_string(row.id) +
                   ") was refused: " + why;
    verdict.reason = reason;
    return verdict;
  }
  if (robot.robot.empty()) robot.robot = row.robot;
  verdict.line = back;
  if (held != maps_.end() && held->second.holds(row.id)) {
    ++robot.rows_repeated;  // A peer that re-sends after a restart.
    verdict.kept = true;
    return verdict;
  }
  if (robot.rows >= static_cast<size_t>(options_.max_rows_per_robot)) {
    // Said once, at the first row past the bound.
    const bool first = robot.rows_past_bound++ == 0;
    ++robot.rows_refused;
    ++robot.refusals["rows bound"];
    verdict.reason = "rows bound";
    if (first) {
      verdict.line = (back.empty() ? "" : back + "; ") + "robot '" + robot.robot + "' (peer " +
                     peer + ") has shared " + std::to_string(robot.rows) +
                     " keyframes, advanced/fleet/max_rows_per_robot: its later ones are not kept "
                     "(its earlier places stay searchable)";
    }
    return verdict;
  }
  auto found = maps_.find(row.map_id);
  if (found == maps_.end()) {
    found = maps_
                .try_emplace(row.map_id, row.robot, peer, maps_.size() + 1, dimension_,
                             options_.search())
                .first;
  }
  found->second.add(row);
  robot.map_ids.insert(row.map_id);
  ++robot.rows;
  verdict.kept = true;
  return verdict;
}

MapScores FleetMatcher::pathScores(const ForeignMap& map, uint64_t map_id, QueryingRun* run) const {
  std::vector<QueryKeyframe> keyframes;
  for (QuerySlot& slot : run->history)
    keyframes.push_back({slot.row.data(), &slot.cosines[map_id]});
  return map.score(keyframes, speeds_);
}

std::optional<FleetCandidate> FleetMatcher::query(const SharedKeyframe& own) {
  if (own.global_row.size() != sizeof(float) + static_cast<size_t>(dimension_)) {
    return std::nullopt;
  }
  // Each querying robot's run chains its own keyframes (a fleet node searches several robots').
  QueryingRun& run =
      runs_.try_emplace({own.map_id, own.session}, options_.index_window).first->second;
  run.history.push_front(QuerySlot{own.global_row, {}});
  while (run.history.size() > static_cast<size_t>(options_.sequence_length)) {
    run.history.pop_back();
  }
  if (run.history.size() < static_cast<size_t>(options_.sequence_length)) {
    // Too short a history for a path: nothing is believed yet (its cosines come when it is).
    run.consistency.reset();
    run.last_candidate.reset();
    return std::nullopt;
  }
  struct Scored {
    const ForeignMap* map;
    size_t index;
    double score;
    bool sampled;  ///< Evidence of what a wrong place of its map scores.
  };
  // Every row of every other map, or of a large one those its search read.
  std::vector<Scored> scored;
  std::map<const ForeignMap*, double> rows_per_sample;
  for (const auto& [map_id, map] : maps_) {
    if (map_id == own.map_id) continue;
    const MapScores scores = pathScores(map, map_id, &run);
    rows_per_sample[&map] = scores.rows_per_sample;
    for (const ScoredRow& row : scores.rows) {
      scored.push_back({&map, row.position, row.score, row.sampled});
    }
  }
  std::vector<Scored> best;
  for (const Scored& row : scored) {
    if (row.score >= options_.min_score) best.push_back(row);
  }
  const size_t keep = std::min(best.size(), static_cast<size_t>(options_.top_k));
  std::partial_sort(best.begin(), best.begin() + keep, best.end(),
                    [](const Scored& a, const Scored& b) { return a.score > b.score; });
  best.resize(keep);
  std::vector<PathPoint> matches;
  for (const Scored& row : best) {
    matches.push_back({(row.map->ordinal() << kMapIdBits) | row.map->row(row.index).id, 0.0});
  }
  const std::vector<TemporalConsistency::Chain> chains =
      run.consistency.update({own.id, 0.0}, matches);
  // Another place of the candidate's map: more than place_window ids away and, in the same
  // session, more than kSamePlaceMetres by its odometry (a robot's second pass of a place is
  // the same place). Other maps are not compared: two robots that both saw the place are not
  // two places.
  const auto other_place_of = [&](const Scored& row, const Scored& candidate) {
    if (row.map != candidate.map) return false;
    const SharedKeyframe& x = row.map->row(row.index);
    const SharedKeyframe& y = candidate.map->row(candidate.index);
    const uint64_t gap = x.id > y.id ? x.id - y.id : y.id - x.id;
    return gap > static_cast<uint64_t>(options_.place_window) &&
           !(x.session == y.session &&
             (x.pose.position - y.pose.position).norm() <= kSamePlaceMetres);
  };
  const auto id_gap = [](uint64_t a, uint64_t b) { return a > b ? a - b : b - a; };
  std::vector<size_t> refused;  // Positions in `best` of candidates refused so far.
  for (size_t k = 0; k < best.size(); ++k) {
    const SharedKeyframe& match = best[k].map->row(best[k].index);
    // A place's best-scoring candidate was refused: a neighbour of it that passes would name
    // the place's wrong keyframe.
    bool off_its_place = false;
    for (const size_t j : refused) {
      const SharedKeyframe& better = best[j].map->row(best[j].index);
      const uint64_t gap = id_gap(better.id, match.id);
      if (best[j].map == best[k].map && gap <= static_cast<uint64_t>(options_.place_window) &&
          gap > static_cast<uint64_t>(options_.index_window)) {
        off_its_place = true;
      }
    }
    // Along the stretch the run's latest candidate named (a few own keyframes back), the match
    // moves as fast as a path may (min to max speed keyframes per own keyframe): farther on is a
    // neighbour of the place.
    if (run.last_candidate && run.last_candidate->map_id == match.map_id &&
        own.id > run.last_candidate->query_id &&
        own.id - run.last_candidate->query_id <= static_cast<uint64_t>(options_.place_window) &&
        id_gap(match.id, run.last_candidate->match_id) <=
            static_cast<uint64_t>(options_.place_window)) {
      const double steps = static_cast<double>(own.id - run.last_candidate->query_id);
      const double advance =
          static_cast<double>(match.id) - static_cast<double>(run.last_candidate->match_id);
      if (advance < std::floor(speeds_.front() * steps) ||
          advance > std::ceil(speeds_.back() * steps)) {
        off_its_place = true;
      }
    }
    refused.push_back(k);  // Unless it is returned below.
    if (off_its_place || chains[k].keyframes < options_.consistent_keyframes) continue;
    // The place-level ratio test: where the keyframe looks about as much like another place of
    // the candidate's map (look-alike bays, a corridor), the best is a guess.
    double other_place = 0.0;
    std::vector<double> other_scores;
    for (const Scored& row : scored) {
      if (!other_place_of(row, best[k])) continue;
      other_place = std::max(other_place, row.score);
      if (row.sampled) other_scores.push_back(row.score);
    }
    if (options_.min_place_ratio > 0.0 && other_place > 0.0 &&
        best[k].score < options_.min_place_ratio * other_place) {
      ++ambiguous_;
      continue;
    }
    // The calibrated decision, as the detector's: so few of the other places are expected to
    // score as high that the candidate may be believed. A candidate that continues the stretch
    // the previous keyframe's candidate began could only be mistaken for the places that would
    // continue it, as the detector counts them.
    const bool continues = run.last_candidate && run.last_candidate->query_id + 1 == own.id &&
                           run.last_candidate->map_id == match.map_id &&
                           id_gap(run.last_candidate->match_id, match.id) <=
                               static_cast<uint64_t>(options_.index_window);
    // A large map's sample stands for the rows its search did not read.
    const size_t other_places = static_cast<size_t>(
        std::llround(static_cast<double>(other_scores.size()) * rows_per_sample.at(best[k].map)));
    const size_t places =
        continues ? std::min(other_places, static_cast<size_t>(2 * options_.index_window + 1))
                  : other_places;
    const ScoreTail tail = fitScoreTail(std::move(other_scores));
    const double false_alarms = options_.max_false_alarms > 0.0 && tail.valid()
                                    ? tail.expectedFalseAlarms(best[k].score, places)
                                    : -1.0;
    if (false_alarms > options_.max_false_alarms) {
      ++ambiguous_;
      continue;
    }
    FleetCandidate candidate;
    candidate.query_map_id = own.map_id;
    candidate.query_id = own.id;
    candidate.query_session = own.session;
    candidate.match = match;
    candidate.peer = best[k].map->peer();
    candidate.score = best[k].score;
    candidate.place_ratio = other_place > 0.0 ? best[k].score / other_place : 0.0;
    candidate.consistent_keyframes = chains[k].keyframes;
    candidate.false_alarms = false_alarms;
    run.last_candidate = QueryingRun::Candidate{own.id, match.map_id, match.id};
    return candidate;  // The best scoring one: `best` is in score order.
  }
  return std::nullopt;  // The latest candidate stays: it still says where the stretch leads.
}

std::vector<std::string> FleetMatcher::checkSilence(double now_s) {
  std::vector<std::string> lines;
  for (auto& [peer, robot] : robots_) {
    if (robot.silent || now_s - robot.last_heard_s < options_.silent_after_s) continue;
    robot.silent = true;
    lines.push_back("peer " + peer + " has shared nothing for " +
                    seconds(now_s - robot.last_heard_s) + ": its " + std::to_string(robot.rows) +
                    " keyframes are kept and still searched");
  }
  return lines;
}

std::vector<FleetRobot> FleetMatcher::robots() const {
  std::vector<FleetRobot> list;
  for (const auto& [name, robot] : robots_) list.push_back(robot);
  return list;
}

size_t FleetMatcher::rows() const {
  size_t count = 0;
  for (const auto& [map_id, map] : maps_) count += map.size();
  return count;
}

size_t FleetMatcher::bytes() const {
  size_t total = 0;
  for (const auto& [map_id, map] : maps_) total += map.bytes();
  return total;
}

CellsOfKeyframe thumbnailCellsOf(const LoopDetector& detector,
                                 const std::vector<uint8_t>& thumbnail) {
  return [&detector, &thumbnail] {
    const cv::Mat image = decodeThumbnail(thumbnail);
    return image.empty() || !detector.extractor()
               ? CellFeatures{}
               : cellFeatures(detector.extractor()->appearanceMaps(image));
  };
}

namespace {

/// Whether two cameras' pinhole values agree within 1 % once scaled to one image size.
bool sameCamera(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  if (a.image_size.area() == 0 || b.image_size.area() == 0) {
    return a.fx == b.fx && a.fy == b.fy && a.cx == b.cx && a.cy == b.cy;
  }
  const CameraIntrinsics scaled = a.scaledTo(b.image_size);
  const auto near = [](double x, double y) { return std::abs(x - y) <= 0.01 * std::abs(y); };
  return near(scaled.fx, b.fx) && near(scaled.fy, b.fy) && near(scaled.cx, b.cx) &&
         near(scaled.cy, b.cy);
}

}  // namespace

PlaceCheck checkFleetCandidate(const GeometricVerifier& verifier,
                               const PlaceCheckSettings& settings, const LocalFeatures& query,
                               const CameraIntrinsics& query_intrinsics,
                               const KeyframeEvidence& match, const CellsOfKeyframe& query_cells_of,
                               const CellsOfKeyframe& match_cells_of, bool appearance_confirms,
                               double false_alarms) {
  PlaceCheck refused;
  const size_t max_keypoints = static_cast<size_t>(std::max(settings.verification.max_features, 0));
  if (const std::string problem = match.problem(max_keypoints); !problem.empty()) {
    refused.detail = "its evidence is malformed: " + problem;
    return refused;
  }
  // Two robots' cameras may differ (another lens, another image size): the match's keypoints,
  // ideal pixels of its own pinhole camera, are moved to the query camera's pixels through their
  // rays (p_query = K_query K_match^-1 p_match). The essential matrix and the metric pose depend on
  // the rays alone, and the match's depths are in its own camera frame, so nothing else changes.
  LocalFeatures match_features = match.local_features;
  if (match_features.image_size != query.image_size ||
      !sameCamera(match.intrinsics, query_intrinsics)) {
    if (!match.intrinsics.valid() || !query_intrinsics.valid() ||
        match_features.image_size.area() == 0 || query.image_size.area() == 0) {
      refused.detail = "the two robots' cameras differ and one has no usable camera_info";
      return refused;
    }
    const CameraIntrinsics from = match.intrinsics.scaledTo(match_features.image_size);
    const CameraIntrinsics to = query_intrinsics.scaledTo(query.image_size);
    for (cv::Point2f& point : match_features.points) {
      point.x = static_cast<float>(to.fx * (point.x - from.cx) / from.fx + to.cx);
      point.y = static_cast<float>(to.fy * (point.y - from.cy) / from.fy + to.cy);
    }
    match_features.image_size = query.image_size;
  }
  std::optional<CellFeatures> query_cells;
  PlaceCheck check =
      checkPlace(verifier, settings, query, match_features, query_intrinsics, &query_cells,
                 query_cells_of, match_cells_of, CandidateCertainty{false_alarms});
  if (check.accepted && !check.place_confirmed) {
    // Unverified (verification off, or no intrinsics): no odometry relates two robots, so an
    // unconfirmed place is never published between them.
    check.accepted = false;
    check.detail = "the place could not be confirmed (verification off or no camera_info)";
  }
  if (check.accepted && check.appearance && !appearance_confirms) {
    check.accepted = false;
    check.detail = "only the appearance check confirmed the place (" + check.detail +
                   "), which advanced/fleet/appearance_confirms does not take between robots";
  }
  return check;
}

}  // namespace landmark_loop_closure
