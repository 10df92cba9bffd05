// Other robots' rows kept as maps of their own, searched for each own keyframe, chained over
// consecutive keyframes, and a fetched candidate checked as the detector checks its own loops.
#include "landmark_loop_closure/fleet/fleet_matcher.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "landmark_loop_closure/common/text_and_files.h"

namespace landmark_loop_closure {

namespace {

/// Chain ids of two maps never come within a place window of each other.
constexpr int kMapIdBits = 40;

std::string seconds(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.0f s", value);
  return text;
}

}  // namespace

const ParameterTable<FleetOptions>& FleetOptions::parameters() {
  using O = FleetOptions;
  static const auto table =
      ParameterTable<O>("fleet/",
                        "loops between robots while they run (README \"Several robots\"): each "
                        "detector shares its keyframes' search rows on ~shared_keyframes and "
                        "answers ~keyframe_evidence; a detector naming peers searches theirs.")
          .flag("share", &O::share,
                "publish each stored keyframe's search row (4.45 KB with the default backbone) "
                "on ~shared_keyframes and answer ~keyframe_evidence for its keypoints and "
                "thumbnail (11.7 KB a candidate on the generated corridor).")
          .text("robot", &O::robot,
                "this robot's name in the rows it shares; empty: the node's namespace.")
          .text("peers", &O::peers,
                "other robots' detector namespaces (e.g. \"/robot_b/loop_closure\"), separated "
                "by spaces or commas: their ~shared_keyframes are kept and searched, and a "
                "candidate's evidence is fetched from their ~keyframe_evidence. Empty: none.")
          .number("min_score", &O::min_score, between(-1, 1),
                  "cosine of the global vectors (the shortlist's, as stored) a keyframe of "
                  "another robot needs to become a candidate.")
          .integer("consistent_keyframes", &O::consistent_keyframes, between(1, 100),
                   "consecutive own keyframes that must match one stretch of another robot's "
                   "map before its evidence is fetched.")
          .integer("place_window", &O::place_window, between(1, 1000),
                   "ids of the other map within which consecutive matches are one stretch.")
          .integer("top_k", &O::top_k, between(1, 100),
                   "candidates kept per keyframe over every other robot's map.")
          .integer("max_rows_per_robot", &O::max_rows_per_robot, between(1, 100000000),
                   "rows kept of one robot (4.45 KB each with the default backbone, 89 MB at the "
                   "default): later ones are refused, with one line, and the earliest places "
                   "stay searchable.")
          .number("silent_after_s", &O::silent_after_s, above(0),
                  "a peer whose rows stop this long is reported silent (its rows are kept); a "
                  "line says when it is back.")
          .number("fetch_timeout_s", &O::fetch_timeout_s, above(0),
                  "a peer's answer for a candidate's evidence is waited for this long; the "
                  "candidate is then given up (the next keyframe may ask again).")
          .flag("appearance_confirms", &O::appearance_confirms,
                "the appearance check alone (where ORB cannot confirm the place: no camera_info, "
                "day against night) may confirm a loop between robots. Off: on the generated "
                "corridor it confirmed 5 look-alike places 21 m apart, which no odometry between "
                "two robots rules out; ORB confirmed none.");
  return table;
}

std::string FleetOptions::validate() const { return parameters().check(*this); }

std::vector<std::string> FleetOptions::peerList() const { return parseNameList(peers); }

FleetMatcher::FleetMatcher(FleetOptions options, const std::string& descriptor_identity,
                           int dimension)
    : options_(std::move(options)),
      fingerprint_(descriptorFingerprint(descriptor_identity)),
      identity_(descriptor_identity),
      dimension_(dimension),
      consistency_(ConsistencyUnit::kKeyframes, options_.place_window) {}

std::string FleetMatcher::addRow(const SharedKeyframe& row, double now_s, uint64_t own_map_id) {
  if (row.map_id == own_map_id) return "";
  FleetRobot& robot = robots_[row.robot];
  robot.robot = row.robot;
  std::string back;
  if (robot.silent) {
    back = "robot '" + row.robot + "' is heard again after " + seconds(now_s - robot.last_heard_s) +
           "; its " + std::to_string(robot.rows) + " keyframes were kept";
    robot.silent = false;
  }
  robot.last_heard_s = now_s;
  const auto refuse = [&](const std::string& why) {
    ++robot.rows_refused;
    return (back.empty() ? "" : back + "; ") + "a shared keyframe from robot '" + row.robot +
           "' (map " + std::to_string(row.map_id) + ", id " + std::to_string(row.id) +
           ") was refused: " + why;
  };
  if (row.descriptor_fingerprint != fingerprint_) {
    return refuse("it was described by another descriptor (fingerprint " +
                  std::to_string(row.descriptor_fingerprint) + ", this detector's " +
                  std::to_string(fingerprint_) + " is " + identity_ +
                  "): both robots need the same descriptor settings and model");
  }
  if (const std::string problem = row.problem(dimension_); !problem.empty()) {
    return refuse(problem);
  }
  const auto held = maps_.find(row.map_id);
  if (held != maps_.end() && held->second.ids.count(row.id) > 0) {
    ++robot.rows_repeated;  // A peer that re-sends after a restart.
    return back;
  }
  if (robot.rows >= static_cast<size_t>(options_.max_rows_per_robot)) {
    // Said once, at the first row past the bound.
    const bool first = robot.rows_past_bound++ == 0;
    ++robot.rows_refused;
    if (!first) return back;
    return (back.empty() ? "" : back + "; ") + "robot '" + row.robot + "' has shared " +
           std::to_string(robot.rows) +
           " keyframes, fleet/max_rows_per_robot: its later ones "
           "are not kept (its earlier places stay searchable)";
  }
  auto [found, added] = maps_.try_emplace(row.map_id);
  ForeignMap& map = found->second;
  if (added) {
    map.robot = row.robot;
    map.ordinal = maps_.size();
    map.vectors = std::make_unique<QuantizedVectors>(dimension_);
  }
  map.ids.insert(row.id);
  robot.map_ids.insert(row.map_id);
  map.vectors->appendRow(row.global_row.data(), row.global_row.size());
  SharedKeyframe kept = row;
  kept.global_row.clear();
  kept.global_row.shrink_to_fit();
  map.rows.push_back(std::move(kept));
  ++robot.rows;
  return back;
}

std::optional<FleetCandidate> FleetMatcher::query(const SharedKeyframe& own) {
  if (own.global_row.size() != sizeof(float) + static_cast<size_t>(dimension_)) {
    return std::nullopt;
  }
  if (query_session_ != own.session) consistency_.reset();
  query_session_ = own.session;
  struct Scored {
    const ForeignMap* map;
    size_t index;
    double score;
  };
  std::vector<Scored> best;
  for (const auto& [map_id, map] : maps_) {
    if (map_id == own.map_id) continue;
    for (size_t index = 0; index < map.rows.size(); ++index) {
      const double score = map.vectors->dot(own.global_row.data(), index);
      if (score < options_.min_score) continue;
      best.push_back({&map, index, score});
    }
  }
  const size_t keep = std::min(best.size(), static_cast<size_t>(options_.top_k));
  std::partial_sort(best.begin(), best.begin() + keep, best.end(),
                    [](const Scored& a, const Scored& b) { return a.score > b.score; });
  best.resize(keep);
  std::vector<PathPoint> matches;
  for (const Scored& scored : best) {
    matches.push_back(
        {(scored.map->ordinal << kMapIdBits) | scored.map->rows[scored.index].id, 0.0});
  }
  const std::vector<TemporalConsistency::Chain> chains =
      consistency_.update({own.id, 0.0}, matches);
  for (size_t k = 0; k < best.size(); ++k) {
    if (chains[k].keyframes < options_.consistent_keyframes) continue;
    FleetCandidate candidate;
    candidate.query_map_id = own.map_id;
    candidate.query_id = own.id;
    candidate.query_session = own.session;
    candidate.match = best[k].map->rows[best[k].index];
    candidate.score = best[k].score;
    candidate.consistent_keyframes = chains[k].keyframes;
    return candidate;  // The best scoring one: `best` is in score order.
  }
  return std::nullopt;
}

std::vector<std::string> FleetMatcher::checkSilence(double now_s) {
  std::vector<std::string> lines;
  for (auto& [name, robot] : robots_) {
    if (robot.silent || now_s - robot.last_heard_s < options_.silent_after_s) continue;
    robot.silent = true;
    lines.push_back("robot '" + name + "' has shared nothing for " +
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
  for (const auto& [map_id, map] : maps_) count += map.rows.size();
  return count;
}

size_t FleetMatcher::bytes() const {
  size_t total = 0;
  for (const auto& [map_id, map] : maps_) {
    total += map.vectors->bytes() + map.rows.capacity() * sizeof(SharedKeyframe) +
             map.ids.size() * (sizeof(uint64_t) + 32);
    for (const SharedKeyframe& row : map.rows) {
      total += row.robot.capacity() + row.odometry_frame.capacity();
    }
  }
  return total;
}

PlaceCheck checkFleetCandidate(const GeometricVerifier& verifier,
                               const PlaceCheckSettings& settings, const LocalFeatures& query,
                               const CameraIntrinsics& query_intrinsics,
                               const KeyframeEvidence& match, const CellsOfKeyframe& query_cells_of,
                               const CellsOfKeyframe& match_cells_of, bool appearance_confirms) {
  PlaceCheck refused;
  if (const std::string problem = match.problem(); !problem.empty()) {
    refused.detail = "its evidence is malformed: " + problem;
    return refused;
  }
  const CameraIntrinsics& other = match.intrinsics;
  const auto near = [](double a, double b) { return std::abs(a - b) <= 0.01 * std::abs(b); };
  if (match.local_features.image_size != query.image_size || !near(other.fx, query_intrinsics.fx) ||
      !near(other.fy, query_intrinsics.fy) || !near(other.cx, query_intrinsics.cx) ||
      !near(other.cy, query_intrinsics.cy)) {
    refused.detail =
        "the two robots' cameras differ (intrinsics or image size): only loops "
        "between like cameras are checked";
    return refused;
  }
  std::optional<CellFeatures> query_cells;
  PlaceCheck check = checkPlace(verifier, settings, query, match.local_features, query_intrinsics,
                                &query_cells, query_cells_of, match_cells_of);
  if (check.accepted && !check.place_confirmed) {
    // Unverified (verification off, or no intrinsics): no odometry relates two robots, so an
    // unconfirmed place is never published between them.
    check.accepted = false;
    check.detail = "the place could not be confirmed (verification off or no camera_info)";
  }
  if (check.accepted && check.appearance && !appearance_confirms) {
    check.accepted = false;
    check.detail = "only the appearance check confirmed the place (" + check.detail +
                   "), which fleet/appearance_confirms does not take between robots";
  }
  return check;
}

}  // namespace landmark_loop_closure
