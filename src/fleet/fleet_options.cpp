// The fleet's parameters (advanced/fleet/), documented once here and generated into
// config/default.yaml.
#include "landmark_loop_closure/common/text_and_files.h"
#include "landmark_loop_closure/fleet/fleet_matcher.h"

namespace landmark_loop_closure {

const ParameterTable<FleetOptions>& FleetOptions::parameters() {
  using O = FleetOptions;
  static const auto table =
      ParameterTable<O>("advanced/fleet/",
                        "loops between robots while they run (docs/robots.md): each "
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
                  "score a keyframe of another robot needs to become a candidate: the best "
                  "path's mean cosine of the global vectors (the shortlist's, as stored), the "
                  "cosine itself with sequence_length 1. With max_false_alarms a floor under "
                  "the calibrated decision, as advanced/acceptance/min_score (a floor of 0.3, "
                  "as before paths, halves the loops between robots on Gardens Point; "
                  "bench/history.md).")
          .integer("sequence_length", &O::sequence_length, between(1, 100),
                   "L > 1: a candidate's score is the best mean cosine along a straight path of "
                   "the last L own keyframes against the other map's keyframes ending at it (as "
                   "advanced/acceptance/sequence_length scores the detector's own loops); nothing "
                   "is a candidate before L own keyframes have come. 1 = single keyframes.")
          .integer("consistent_keyframes", &O::consistent_keyframes, between(1, 100),
                   "consecutive own keyframes that must match one stretch of another robot's "
                   "map before its evidence is fetched.")
          .integer("place_window", &O::place_window, between(1, 1000),
                   "ids of the other map within which two matches are one place.")
          .integer("index_window", &O::index_window, between(0, 1000),
                   "ids of the other map within which consecutive own keyframes' matches "
                   "continue each other (the chain, a continuing loop), and within which a "
                   "candidate must lie of its place's best-scoring one, as "
                   "advanced/acceptance/index_window: a path that agrees on the place names its "
                   "keyframe, not a neighbour.")
          .integer("top_k", &O::top_k, between(1, 100),
                   "candidates kept per keyframe over every other robot's map.")
          .integer("approximate_from", &O::approximate_from, between(0, 100000000),
                   "rows of one map from which a search reads only the rows an HNSW graph finds "
                   "nearest the last sequence_length own keyframes (nearest_rows each), the paths "
                   "through them, and a fixed sample of at most 256 rows for the calibrated "
                   "decision's tail (standing for the rows not read), so that its time does not "
                   "grow with the fleet's maps: 1.5-2.0 ms a keyframe at 4 maps of 5 000 rows "
                   "against 8.5-9 ms reading every row, the same candidates (lcd_bench_pipeline "
                   "--fleet-rows 20000). Below it every row is read, as on the maps bench/README "
                   "measures. The graph grows with each map from its first row (about 200 B a "
                   "row). 0 = every row, always (no graph).")
          .integer("nearest_rows", &O::nearest_rows, between(1, 10000),
                   "with approximate_from: rows the graph returns per own keyframe and map.")
          .integer("max_rows_per_robot", &O::max_rows_per_robot, between(1, 100000000),
                   "rows kept of one robot (4.45 KB each with the default backbone, 89 MB at the "
                   "default): later ones are refused, with one line, and the earliest places "
                   "stay searchable.")
          .integer("max_maps_per_robot", &O::max_maps_per_robot, between(1, 100000),
                   "maps (a map_id: a map file or a reset) kept of one peer: rows of more are "
                   "refused, with one line; what it shared before stays searchable.")
          .number("silent_after_s", &O::silent_after_s, above(0),
                  "a peer whose rows stop this long is reported silent (its rows are kept); a "
                  "line says when it is back.")
          .number("fetch_timeout_s", &O::fetch_timeout_s, above(0),
                  "a peer's answer for a candidate's evidence is waited for this long; the "
                  "request is then ended (its connection dropped) and the candidate given up. "
                  "One request is out per peer at a time: a candidate of a peer that has one out "
                  "is skipped and counted (the next keyframe may ask again).")
          .number("evidence_requests_per_s", &O::evidence_requests_per_s, between(1, 10000),
                  "with share: evidence requests answered a second per caller (bursts of as "
                  "many), all callers together 4 times as many; past it a request is answered "
                  "`found: false` without reading the map. A peer asks at most one at a time.")
          .number("backlog_rows_per_s", &O::backlog_rows_per_s, between(1, 100000),
                  "with share: a peer that subscribes later (started after this robot, or "
                  "restarted) is sent the map's rows so far, at most this many a second (500: "
                  "2.2 MB/s with the default backbone), beside the new ones; rows it holds "
                  "already are not kept twice. A map loaded from database_path is shared so too.")
          .number("min_place_ratio", &O::min_place_ratio, between(0, 100),
                  "a chained candidate's score over the best score of another place of its map "
                  "must reach this (0 = off): where a keyframe looks about as much like several "
                  "places (look-alike bays), the best is a guess. Another place: more than "
                  "place_window ids away and, in the same session, more than 2.5 m away by its "
                  "odometry; other robots' maps are not compared (two robots that saw the place "
                  "are not two places). It decides alone on maps too small for the tail below "
                  "(under 20 other places); beside it, it changed nothing on the corridors.")
          .number("max_false_alarms", &O::max_false_alarms, between(0, 1000000),
                  "the calibrated decision (0 = off), as advanced/acceptance/max_false_alarms: a "
                  "chained "
                  "candidate is believed only where fewer wrong places than this are expected to "
                  "score as high, from an exponential tail fitted to what the other places of "
                  "its map scored against the keyframe's path (a candidate that continues the "
                  "previous keyframe's stretch counts only the places that would continue it). "
                  "0.03: the largest of 0.003, 0.03, 0.1, 0.3 with no wrong loop on the first "
                  "halves of Gardens Point and Nordland as two robots (all four) and on the "
                  "generated corridors (0.1 published 1 wrong of 51 on the aliasing corridor), "
                  "reported on the second halves (bench/README.md).")
          .flag("appearance_confirms", &O::appearance_confirms,
                "the appearance check alone (where ORB cannot confirm the place: day against "
                "night, a large change of view) may confirm a loop between robots, as it does "
                "the detector's own. Off: only ORB confirms (Gardens Point day -> night as two "
                "robots then finds none; with it 51 of 100, none wrong; without the calibrated "
                "decision it confirmed 5 look-alike places 21 m apart on the corridor).");
  return table;
}

std::string FleetOptions::validate() const { return parameters().check(*this); }

std::vector<std::string> FleetOptions::peerList() const { return parseNameList(peers); }

ForeignSearchOptions FleetOptions::search() const {
  ForeignSearchOptions search;
  search.approximate_from = approximate_from;
  search.nearest = nearest_rows;
  return search;
}

}  // namespace landmark_loop_closure
