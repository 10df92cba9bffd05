// Loops between robots (issue 68): another robot's shared rows kept, refused with one line when
// they cannot be used, searched and chained; a candidate's fetched evidence checked as the
// detector's own loops are.
#include <condition_variable>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "landmark_loop_closure/fleet/fleet_matcher.h"
#include "landmark_loop_closure/fleet/fleet_searcher.h"

namespace landmark_loop_closure {
namespace {

constexpr int kDimension = 8;
const std::string kIdentity = "test descriptor";

std::vector<float> unit(std::vector<float> vector) {
  float norm = 0.0f;
  for (const float value : vector) norm += value * value;
  for (float& value : vector) value /= std::sqrt(norm);
  return vector;
}

/// A unit vector pointing mostly along axis `place` (places 0..7 are far apart).
std::vector<float> placeVector(int place, float noise = 0.0f) {
  std::vector<float> vector(kDimension, noise);
  vector[place % kDimension] = 1.0f;
  return unit(vector);
}

SharedKeyframe row(const std::string& robot, uint64_t map_id, uint64_t id, int place) {
  SharedKeyframe shared;
  shared.robot = robot;
  shared.map_id = map_id;
  shared.id = id;
  shared.stamp_ns = static_cast<int64_t>(id + 1) * 1000000000;
  shared.odometry_frame = robot + "/odom";
  shared.descriptor_fingerprint = descriptorFingerprint(kIdentity);
  shared.global_row = QuantizedVectors::encode(placeVector(place, 0.05f));
  return shared;
}

/// Single keyframes (sequence_length 1): the chain alone joins consecutive keyframes.
FleetOptions options() {
  FleetOptions fleet;
  fleet.min_score = 0.9;
  fleet.sequence_length = 1;
  fleet.consistent_keyframes = 3;
  fleet.place_window = 2;
  return fleet;
}

/// Places along robot a's route: each appears three to six times; three in a row appear once,
/// at any of the paths' speeds.
const std::vector<int> kRoute = {5, 0, 0, 4, 1, 0, 2, 3, 4, 6, 5, 4, 1, 6, 7, 6,
                                 5, 6, 3, 6, 2, 1, 7, 3, 4, 2, 7, 5, 2, 0, 6, 7};

// Each keyframe of robot b looks as much like four places of robot a's map: alone it is a guess.
// Three in a row name one stretch of a's route, and the path through it finds the right ids.
TEST(FleetMatcher, AStretchOfKeyframesFindsWhatEachAloneCannot) {
  const auto run = [](int length) {
    FleetOptions fleet = options();
    fleet.sequence_length = length;
    fleet.consistent_keyframes = 1;
    fleet.max_false_alarms = 0.0;
    FleetMatcher matcher(fleet, kIdentity, kDimension);
    for (uint64_t id = 0; id < kRoute.size(); ++id) {
      SharedKeyframe kept = row("a", 1, id, kRoute[id]);
      kept.pose.position.x() = 5.0 * static_cast<double>(id);  // Each id another place.
      EXPECT_EQ(matcher.addRow(kept, 0.0, 2), "");
    }
    std::vector<std::optional<FleetCandidate>> found;
    for (uint64_t id = 0; id < 6; ++id) {
      found.push_back(matcher.query(row("b", 2, id, kRoute[10 + id])));
    }
    return found;
  };
  for (const auto& candidate : run(1)) EXPECT_FALSE(candidate);
  const std::vector<std::optional<FleetCandidate>> found = run(3);
  EXPECT_FALSE(found[0]);  // Fewer keyframes than a path: nothing is believed yet.
  EXPECT_FALSE(found[1]);
  for (uint64_t id = 2; id < 6; ++id) {
    ASSERT_TRUE(found[id]) << id;
    EXPECT_EQ(found[id]->match.id, 10 + id);
    EXPECT_GT(found[id]->score, 0.9);
    EXPECT_GE(found[id]->place_ratio, 1.3);
  }
}

/// A unit vector of its own for each id below 64: two axes mixed.
SharedKeyframe distinctRow(const std::string& robot, uint64_t map_id, uint64_t id, uint64_t look) {
  SharedKeyframe shared = row(robot, map_id, id, 0);
  std::vector<float> vector(kDimension, 0.0f);
  vector[look % kDimension] += 1.0f;
  vector[(look / kDimension + 3) % kDimension] += 0.6f;
  shared.global_row = QuantizedVectors::encode(unit(vector));
  return shared;
}

// Robot b's matches walk along robot a's map; a keyframe whose best match runs ahead of the
// stretch faster than a path may (here one id per keyframe) names a neighbour of its place and
// is refused, and the stretch goes on where it leads.
TEST(FleetMatcher, AMatchThatRunsAheadOfItsStretchIsANeighbourAndRefused) {
  FleetOptions fleet = options();
  fleet.consistent_keyframes = 1;
  fleet.place_window = 10;
  fleet.index_window = 3;
  fleet.top_k = 1;
  fleet.min_place_ratio = 0.0;
  fleet.max_false_alarms = 0.0;
  FleetMatcher matcher(fleet, kIdentity, kDimension);
  for (uint64_t id = 0; id < 30; ++id) matcher.addRow(distinctRow("a", 1, id, id), 0.0, 2);
  const auto found = [&](uint64_t query, uint64_t look) -> int64_t {
    const std::optional<FleetCandidate> candidate = matcher.query(distinctRow("b", 2, query, look));
    return candidate ? static_cast<int64_t>(candidate->match.id) : -1;
  };
  EXPECT_EQ(found(0, 10), 10);
  EXPECT_EQ(found(1, 11), 11);
  EXPECT_EQ(found(2, 14), -1);  // Three ids on in one keyframe.
  EXPECT_EQ(found(3, 13), 13);  // Two keyframes after 11: where the stretch leads.
}

// Rows of robot a's first pass arrive after its later ones (a backlog sent once b subscribed):
// paths follow a's ids, not the order the rows came in.
TEST(FleetMatcher, PathsFollowTheOtherMapsIdsWhateverOrderItsRowsCameIn) {
  FleetOptions fleet = options();
  fleet.sequence_length = 3;
  fleet.consistent_keyframes = 1;
  fleet.max_false_alarms = 0.0;
  FleetMatcher matcher(fleet, kIdentity, kDimension);
  for (uint64_t id = 16; id < kRoute.size(); ++id) {
    SharedKeyframe kept = row("a", 1, id, kRoute[id]);
    kept.pose.position.x() = 5.0 * static_cast<double>(id);
    matcher.addRow(kept, 0.0, 2);
  }
  for (uint64_t id = 0; id < 16; ++id) {
    SharedKeyframe kept = row("a", 1, id, kRoute[id]);
    kept.pose.position.x() = 5.0 * static_cast<double>(id);
    matcher.addRow(kept, 0.0, 2);
  }
  std::optional<FleetCandidate> last;
  for (uint64_t id = 0; id < 5; ++id) last = matcher.query(row("b", 2, id, kRoute[12 + id]));
  ASSERT_TRUE(last);
  EXPECT_EQ(last->match.id, 16u);  // Its path runs over ids 14, 15 (late) and 16 (early).
}

TEST(FleetMatcher, ACandidateNeedsItsChainOfConsecutiveKeyframes) {
  FleetMatcher matcher(options(), kIdentity, kDimension);
  // Robot a's map 1: ids 0..7 at places 0..7.
  for (uint64_t id = 0; id < 8; ++id) {
    EXPECT_EQ(matcher.addRow(row("a", 1, id, static_cast<int>(id)), 0.0, 2), "");
  }
  EXPECT_EQ(matcher.rows(), 8u);
  // Robot b (map 2) drives places 2, 3, 4, 5: a candidate from the third keyframe on.
  std::vector<std::optional<FleetCandidate>> found;
  for (uint64_t id = 0; id < 4; ++id) {
    found.push_back(matcher.query(row("b", 2, id, static_cast<int>(id + 2))));
  }
  EXPECT_FALSE(found[0]);
  EXPECT_FALSE(found[1]);
  ASSERT_TRUE(found[2]);
  EXPECT_EQ(found[2]->match.map_id, 1u);
  EXPECT_EQ(found[2]->match.id, 4u);
  EXPECT_EQ(found[2]->match.robot, "a");
  EXPECT_EQ(found[2]->query_id, 2u);
  EXPECT_EQ(found[2]->query_map_id, 2u);
  EXPECT_EQ(found[2]->consistent_keyframes, 3);
  EXPECT_GT(found[2]->score, 0.9);
  ASSERT_TRUE(found[3]);
  EXPECT_EQ(found[3]->match.id, 5u);
}

TEST(FleetMatcher, MatchesJumpingAcrossTheOtherMapBreakTheChain) {
  FleetMatcher matcher(options(), kIdentity, kDimension);
  for (uint64_t id = 0; id < 40; ++id) {
    matcher.addRow(row("a", 1, id, static_cast<int>(id % kDimension)), 0.0, 2);
  }
  // Places 0, 1, 2 of a's map repeat every 8 ids: the best match of each query is one of them,
  // but consecutive queries of places 0 then 4 then 0 never chain within place_window ids.
  int candidates = 0;
  for (uint64_t id = 0; id < 12; ++id) {
    candidates += matcher.query(row("b", 2, id, id % 2 == 0 ? 0 : 4)) ? 1 : 0;
  }
  EXPECT_EQ(candidates, 0);
}

// Robot a's map holds two look-alike places (ids 0-7 and 20-27 show the same places 0-7, as
// bays of a corridor do): a keyframe of robot b there matches both equally, and is refused
// whatever its chain, while a place a's map holds once is found.
TEST(FleetMatcher, APlaceThatLooksLikeAnotherOfTheSameMapIsAGuessAndRefused) {
  FleetMatcher matcher(options(), kIdentity, kDimension);
  for (uint64_t id = 0; id < 8; ++id) {
    matcher.addRow(row("a", 1, id, static_cast<int>(id)), 0.0, 2);
    SharedKeyframe twin = row("a", 1, id + 20, static_cast<int>(id));
    twin.pose.position.x() = 40.0;  // Far along a's route: another place.
    matcher.addRow(twin, 0.0, 2);
  }
  int candidates = 0;
  for (uint64_t id = 0; id < 6; ++id) {
    candidates += matcher.query(row("b", 2, id, static_cast<int>(id))) ? 1 : 0;
  }
  EXPECT_EQ(candidates, 0);
  EXPECT_GT(matcher.ambiguous(), 0u);

  // The same rows, the twins being one place by a's odometry (a second pass within 2.5 m):
  // not two places, and the chain finds them.
  FleetMatcher one_place(options(), kIdentity, kDimension);
  for (uint64_t id = 0; id < 8; ++id) {
    one_place.addRow(row("a", 1, id, static_cast<int>(id)), 0.0, 2);
    one_place.addRow(row("a", 1, id + 20, static_cast<int>(id)), 0.0, 2);
  }
  candidates = 0;
  for (uint64_t id = 0; id < 6; ++id) {
    candidates += one_place.query(row("b", 2, id, static_cast<int>(id))) ? 1 : 0;
  }
  EXPECT_EQ(candidates, 4);
}

// A place two other robots both saw is one place, not two: robot c finds it in either map.
TEST(FleetMatcher, APlaceSeenByTwoRobotsIsNotAmbiguous) {
  FleetMatcher matcher(options(), kIdentity, kDimension);
  for (uint64_t id = 0; id < 8; ++id) {
    matcher.addRow(row("a", 1, id, static_cast<int>(id)), 0.0, 3);
    matcher.addRow(row("b", 2, id, static_cast<int>(id)), 0.0, 3);
  }
  int candidates = 0;
  for (uint64_t id = 0; id < 6; ++id) {
    candidates += matcher.query(row("c", 3, id, static_cast<int>(id))) ? 1 : 0;
  }
  EXPECT_EQ(candidates, 4);
  EXPECT_EQ(matcher.ambiguous(), 0u);
}

TEST(FleetMatcher, RowsThatCannotBeUsedAreRefusedWithOneLineEach) {
  FleetMatcher matcher(options(), kIdentity, kDimension);
  SharedKeyframe other_descriptor = row("a", 1, 0, 0);
  other_descriptor.descriptor_fingerprint = descriptorFingerprint("another network");
  std::string line = matcher.addRow(other_descriptor, 0.0, 2);
  EXPECT_NE(line.find("peer a (map 1, id 0) was refused: it was described by another "
                      "descriptor"),
            std::string::npos)
      << line;
  EXPECT_NE(line.find(kIdentity), std::string::npos) << line;

  SharedKeyframe short_vector = row("a", 1, 1, 0);
  short_vector.global_row.resize(6);
  line = matcher.addRow(short_vector, 0.0, 2);
  EXPECT_NE(line.find("a global vector of 2 values where this detector's have 8"),
            std::string::npos)
      << line;

  SharedKeyframe bad_scale = row("a", 1, 2, 0);
  const float nan = std::nanf("");
  std::memcpy(bad_scale.global_row.data(), &nan, sizeof(float));
  EXPECT_NE(matcher.addRow(bad_scale, 0.0, 2).find("scale that is not finite"), std::string::npos);

  SharedKeyframe bad_pose = row("a", 1, 3, 0);
  bad_pose.pose.orientation = Eigen::Quaterniond(0, 0, 0, 0);
  EXPECT_NE(matcher.addRow(bad_pose, 0.0, 2).find("not a unit quaternion"), std::string::npos);
  SharedKeyframe nameless = row("", 1, 4, 0);
  EXPECT_NE(matcher.addRow(nameless, 0.0, 2).find("no robot name"), std::string::npos);

  EXPECT_EQ(matcher.rows(), 0u);
  ASSERT_EQ(matcher.robots().size(), 2u);
  EXPECT_EQ(matcher.robots()[1].rows_refused, 4u);
  // A good row after them is kept.
  EXPECT_EQ(matcher.addRow(row("a", 1, 5, 0), 0.0, 2), "");
  EXPECT_EQ(matcher.rows(), 1u);
}

TEST(FleetMatcher, OwnRowsRepeatsAndRowsPastTheBoundAreNotKept) {
  FleetOptions bounded = options();
  bounded.max_rows_per_robot = 3;
  FleetMatcher matcher(bounded, kIdentity, kDimension);
  // Its own map, echoed back (or sent by a peer that claims it): refused, with a line.
  EXPECT_NE(matcher.addRow(row("b", 2, 0, 0), 0.0, 2).find("this detector's own map"),
            std::string::npos);
  EXPECT_EQ(matcher.rows(), 0u);
  for (uint64_t id = 0; id < 3; ++id) EXPECT_EQ(matcher.addRow(row("a", 1, id, 0), 0.0, 2), "");
  EXPECT_EQ(matcher.addRow(row("a", 1, 1, 0), 0.0, 2), "");  // Sent again after a restart.
  const std::string past = matcher.addRow(row("a", 1, 3, 0), 0.0, 2);
  EXPECT_NE(
      past.find("robot 'a' (peer a) has shared 3 keyframes, advanced/fleet/max_rows_per_robot"),
      std::string::npos)
      << past;
  EXPECT_EQ(matcher.addRow(row("a", 1, 4, 0), 0.0, 2), "");  // Said once.
  EXPECT_EQ(matcher.rows(), 3u);
  const FleetRobot robot = matcher.robots().front();
  EXPECT_EQ(robot.rows_repeated, 1u);
  EXPECT_EQ(robot.rows_refused, 2u);
  EXPECT_GT(matcher.bytes(), 3u * (4 + kDimension));
}

TEST(FleetMatcher, ASilentRobotIsReportedOnceAndWelcomedBack) {
  FleetMatcher matcher(options(), kIdentity, kDimension);
  for (uint64_t id = 0; id < 8; ++id) matcher.addRow(row("a", 1, id, static_cast<int>(id)), 5.0, 2);
  EXPECT_TRUE(matcher.checkSilence(20.0).empty());
  const std::vector<std::string> silent = matcher.checkSilence(66.0);
  ASSERT_EQ(silent.size(), 1u);
  EXPECT_EQ(silent[0],
            "peer a has shared nothing for 61 s: its 8 keyframes are kept and "
            "still searched");
  EXPECT_TRUE(matcher.checkSilence(90.0).empty());
  // Its rows are still searched while it is silent.
  int candidates = 0;
  for (uint64_t id = 0; id < 4; ++id) {
    candidates += matcher.query(row("b", 2, id, static_cast<int>(id))) ? 1 : 0;
  }
  EXPECT_EQ(candidates, 2);
  const std::string back = matcher.addRow(row("a", 1, 8, 0), 125.0, 2);
  EXPECT_EQ(back, "peer a is heard again after 120 s; its 8 keyframes were kept");
  EXPECT_EQ(matcher.rows(), 9u);
}

// What a peer sends is untrusted: a row is validated whole before anything is kept, the peer (the
// subscription) keys every bound, and names or ids it invents create no state.
TEST(FleetMatcher, APeerCannotInventRobotsMapsOrIdsPastItsBounds) {
  FleetOptions bounded = options();
  bounded.max_maps_per_robot = 2;
  FleetMatcher matcher(bounded, kIdentity, kDimension);
  const std::string peer = "/robot_a/loop_closure";
  EXPECT_TRUE(matcher.addRowFrom(peer, row("a", 1, 0, 0), 0.0, 9).kept);
  // A new robot name in every row: refused, counted under the one peer.
  for (int k = 0; k < 100; ++k) {
    const RowVerdict verdict =
        matcher.addRowFrom(peer, row("invented_" + std::to_string(k), 1, 1 + k, 0), 0.0, 9);
    EXPECT_FALSE(verdict.kept);
    EXPECT_EQ(verdict.reason, "robot name");
  }
  // A name too long to log, one that is not printable, an id that would alias another map's
  // chain ids, an odometry frame name of a megabyte, a NaN pose, this detector's own map.
  const RowVerdict long_name =
      matcher.addRowFrom(peer, row(std::string(1 << 20, 'x'), 1, 200, 0), 0.0, 9);
  EXPECT_EQ(long_name.reason, "robot name");
  EXPECT_LT(long_name.line.size(), 300u) << "the name is not repeated";
  EXPECT_EQ(matcher.addRowFrom(peer, row("a\n", 1, 201, 0), 0.0, 9).reason, "robot name");
  EXPECT_EQ(matcher.addRowFrom(peer, row("a", 1, uint64_t{1} << 40, 0), 0.0, 9).reason, "id range");
  SharedKeyframe long_frame = row("a", 1, 202, 0);
  long_frame.odometry_frame.assign(1 << 20, 'f');
  EXPECT_EQ(matcher.addRowFrom(peer, long_frame, 0.0, 9).reason, "frame name");
  SharedKeyframe nan_pose = row("a", 1, 203, 0);
  nan_pose.pose.position.x() = std::nan("");
  EXPECT_EQ(matcher.addRowFrom(peer, nan_pose, 0.0, 9).reason, "malformed");
  const RowVerdict own = matcher.addRowFrom(peer, row("a", 9, 204, 0), 0.0, 9);
  EXPECT_FALSE(own.kept);
  EXPECT_EQ(own.reason, "own map");
  // Another peer cannot add to (or redirect evidence requests for) a map the first one shared.
  EXPECT_EQ(matcher.addRowFrom("/robot_c/loop_closure", row("c", 1, 300, 0), 0.0, 9).reason,
            "map of another peer");
  // Maps per peer are bounded.
  EXPECT_TRUE(matcher.addRowFrom(peer, row("a", 2, 0, 0), 0.0, 9).kept);
  EXPECT_EQ(matcher.addRowFrom(peer, row("a", 3, 0, 0), 0.0, 9).reason, "maps bound");

  EXPECT_EQ(matcher.rows(), 2u);
  const std::vector<FleetRobot> robots = matcher.robots();
  ASSERT_EQ(robots.size(), 2u);  // The two peers, never a name a row gave.
  const FleetRobot& a = robots.front();
  EXPECT_EQ(a.peer, peer);
  EXPECT_EQ(a.robot, "a");
  EXPECT_EQ(a.map_ids.size(), 2u);
  EXPECT_EQ(a.refusals.at("robot name"), 102u);
  EXPECT_EQ(a.refusals.at("id range"), 1u);
  EXPECT_EQ(a.refusals.at("maps bound"), 1u);
  // A candidate names the peer that shared its map, for its evidence.
  FleetMatcher single(options(), kIdentity, kDimension);
  for (uint64_t id = 0; id < 6; ++id) {
    single.addRowFrom(peer, row("a", 1, id, static_cast<int>(id)), 0.0, 9);
  }
  std::optional<FleetCandidate> candidate;
  for (uint64_t id = 0; id < 6 && !candidate; ++id) {
    candidate = single.query(row("b", 9, id, static_cast<int>(id)));
  }
  ASSERT_TRUE(candidate);
  EXPECT_EQ(candidate->peer, peer);
}

/// Paths of three keyframes, each believed alone, over robot a's route (each id another place).
FleetOptions pathOptions() {
  FleetOptions fleet = options();
  fleet.sequence_length = 3;
  fleet.consistent_keyframes = 1;
  fleet.max_false_alarms = 0.0;
  return fleet;
}

void addRoute(FleetMatcher& matcher) {
  for (uint64_t id = 0; id < kRoute.size(); ++id) {
    SharedKeyframe kept = row("a", 1, id, kRoute[id]);
    kept.pose.position.x() = 5.0 * static_cast<double>(id);
    matcher.addRow(kept, 0.0, 2);
  }
}

// The worker hands its rows to the searcher and goes on; the searcher's thread finds what the
// matcher itself finds, and a searcher that falls behind drops the oldest rows, counted.
TEST(FleetSearcher, SearchesOffTheCallersThreadAndDropsTheOldestWhenBehind) {
  const FleetOptions fleet = pathOptions();
  FleetMatcher matcher(fleet, kIdentity, kDimension);
  Mutex matcher_mutex;
  addRoute(matcher);
  std::mutex mutex;
  std::condition_variable changed;
  bool entered = false, hold = false;
  std::vector<std::pair<uint64_t, uint64_t>> found;  // (own id, match id)
  FleetSearcher searcher(matcher, matcher_mutex, 4,
                         [&](const FleetSearcher::Search& own,
                             std::optional<FleetCandidate> candidate, double milliseconds) {
                           EXPECT_GE(milliseconds, 0.0);
                           std::unique_lock<std::mutex> lock(mutex);
                           if (candidate) {
                             EXPECT_EQ(candidate->query_map_id, 7u);
                             found.emplace_back(own.row.id, candidate->match.id);
                           }
                           entered = true;
                           changed.notify_all();
                           changed.wait(lock, [&] { return !hold; });
                         });
  for (uint64_t id = 0; id < 6; ++id) {
    searcher.hand({row("b", 2, id, kRoute[10 + id]), 7, "odom"});
    searcher.drain();
  }
  EXPECT_EQ(searcher.searched(), 6u);
  EXPECT_EQ(searcher.dropped(), 0u);
  // What the same matcher, asked on this thread, finds.
  FleetMatcher direct(fleet, kIdentity, kDimension);
  addRoute(direct);
  std::vector<std::pair<uint64_t, uint64_t>> expected;
  for (uint64_t id = 0; id < 6; ++id) {
    if (const auto candidate = direct.query(row("b", 2, id, kRoute[10 + id]))) {
      expected.emplace_back(id, candidate->match.id);
    }
  }
  EXPECT_FALSE(expected.empty());
  EXPECT_EQ(found, expected);
  // Held inside a search, the searcher keeps the newest 4 of 20 rows and drops the rest.
  {
    std::lock_guard<std::mutex> lock(mutex);
    hold = true;
    entered = false;
  }
  searcher.hand({row("b", 2, 100, 0), 7, "odom"});
  {
    std::unique_lock<std::mutex> lock(mutex);
    changed.wait(lock, [&] { return entered; });
  }
  for (uint64_t id = 101; id <= 120; ++id) searcher.hand({row("b", 2, id, 0), 7, "odom"});
  EXPECT_EQ(searcher.dropped(), 16u);
  {
    std::lock_guard<std::mutex> lock(mutex);
    hold = false;
  }
  changed.notify_all();
  searcher.drain();
  EXPECT_EQ(searcher.searched(), 6u + 1u + 4u);
  searcher.stop();
  searcher.hand({row("b", 2, 200, 0), 7, "odom"});  // After stop: ignored, nothing waits.
  EXPECT_EQ(searcher.searched(), 11u);
}

TEST(FleetMatcher, PeerListsSplitOnSpacesAndCommas) {
  FleetOptions fleet;
  fleet.peers = " /robot_b/loop_closure,/robot_c/loop_closure  /robot_b/loop_closure ";
  EXPECT_EQ(fleet.peerList(),
            (std::vector<std::string>{"/robot_b/loop_closure", "/robot_c/loop_closure"}));
  EXPECT_EQ(fleet.validate(), "");
  fleet.min_score = 2.0;
  EXPECT_NE(fleet.validate(), "");
}

TEST(FleetCandidateCheck, MalformedEvidenceAndOtherCamerasAreRefused) {
  const VerificationOptions verification;
  const AppearanceCheckOptions appearance;
  const MetricPoseOptions metric;
  const GeometricVerifier verifier(verification);
  CameraIntrinsics camera;
  camera.fx = camera.fy = 300;
  camera.cx = 320;
  camera.cy = 240;
  camera.image_size = cv::Size(640, 480);
  LocalFeatures query;
  KeyframeEvidence evidence;
  evidence.intrinsics = camera;
  evidence.local_features.points.resize(5);
  const auto no_cells = [] { return CellFeatures{}; };
  PlaceCheck check = checkFleetCandidate(verifier, {verification, appearance, metric}, query,
                                         camera, evidence, no_cells, no_cells, false);
  EXPECT_FALSE(check.accepted);
  EXPECT_EQ(check.detail,
            "its evidence is malformed: 5 keypoints without a 32-byte descriptor each");

  // Another camera is checked through its rays, which needs its camera_info.
  evidence.local_features = LocalFeatures{};
  evidence.intrinsics = CameraIntrinsics{};
  query.image_size = camera.image_size;
  check = checkFleetCandidate(verifier, {verification, appearance, metric}, query, camera, evidence,
                              no_cells, no_cells, false);
  EXPECT_FALSE(check.accepted);
  EXPECT_NE(check.detail.find("cameras differ and one has no usable camera_info"),
            std::string::npos)
      << check.detail;

  // Without camera_info the detector may publish its own loop unverified; between robots never.
  const CameraIntrinsics unknown;
  evidence.intrinsics = unknown;
  evidence.local_features.image_size = query.image_size;
  check = checkFleetCandidate(verifier, {verification, appearance, metric}, query, unknown,
                              evidence, no_cells, no_cells, false);
  EXPECT_FALSE(check.accepted);
  EXPECT_NE(check.detail.find("could not be confirmed"), std::string::npos) << check.detail;
}

TEST(FleetCandidateCheck, AnotherRobotsCameraIsCheckedThroughItsRays) {
  // The query camera: 640x480, fx 300. The other robot's: 960x540, fx 800, 0.4 m to the side and
  // turned 4 degrees about the vertical; both see 300 points 3-8 m ahead.
  CameraIntrinsics query_camera;
  query_camera.fx = query_camera.fy = 300;
  query_camera.cx = 320;
  query_camera.cy = 240;
  query_camera.image_size = cv::Size(640, 480);
  CameraIntrinsics match_camera;
  match_camera.fx = match_camera.fy = 800;
  match_camera.cx = 480;
  match_camera.cy = 270;
  match_camera.image_size = cv::Size(960, 540);
  const double yaw = 4.0 * M_PI / 180.0;
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).matrix();
  const Eigen::Vector3d translation(0.4, 0.0, 0.05);  // X_query = rotation * X_match + t.
  cv::RNG random(7);
  LocalFeatures query, match;
  query.image_size = query_camera.image_size;
  match.image_size = match_camera.image_size;
  std::vector<cv::Mat> rows;
  while (query.points.size() < 300) {
    const Eigen::Vector3d in_match((random.uniform(-1.0, 1.0)), random.uniform(-0.5, 0.5),
                                   random.uniform(3.0, 8.0));
    const Eigen::Vector3d in_query = rotation * in_match + translation;
    const cv::Point2f match_pixel(
        static_cast<float>(match_camera.fx * in_match.x() / in_match.z() + match_camera.cx),
        static_cast<float>(match_camera.fy * in_match.y() / in_match.z() + match_camera.cy));
    const cv::Point2f query_pixel(
        static_cast<float>(query_camera.fx * in_query.x() / in_query.z() + query_camera.cx),
        static_cast<float>(query_camera.fy * in_query.y() / in_query.z() + query_camera.cy));
    if (!cv::Rect2f(0, 0, 960, 540).contains(match_pixel) ||
        !cv::Rect2f(0, 0, 640, 480).contains(query_pixel)) {
      continue;
    }
    match.points.push_back(match_pixel);
    query.points.push_back(query_pixel);
    match.points3d.emplace_back(static_cast<float>(in_match.x()), static_cast<float>(in_match.y()),
                                static_cast<float>(in_match.z()));
    match.depth_sd.push_back(0.01f);
    cv::Mat row(1, 32, CV_8U);
    random.fill(row, cv::RNG::UNIFORM, 0, 256);
    rows.push_back(row);
  }
  cv::vconcat(rows, query.descriptors);
  match.descriptors = query.descriptors.clone();
  KeyframeEvidence evidence;
  evidence.intrinsics = match_camera;
  evidence.local_features = match;
  const VerificationOptions verification;
  const GeometricVerifier verifier(verification);
  const auto no_cells = [] { return CellFeatures{}; };
  const PlaceCheck check = checkFleetCandidate(verifier, {verification, {}, {}}, query,
                                               query_camera, evidence, no_cells, no_cells, false);
  ASSERT_TRUE(check.accepted) << check.detail;
  EXPECT_GT(check.inliers, 250);
  ASSERT_TRUE(check.relative_pose.has_value());
  // The metric pose from the match's depths: where the other camera is.
  const Eigen::Vector3d found(check.relative_pose->translation);
  EXPECT_LT((found - translation).norm(), 0.02) << found.transpose();
  EXPECT_LT(Eigen::AngleAxisd(check.relative_pose->rotation * rotation.transpose()).angle(),
            0.2 * M_PI / 180.0);
}

}  // namespace
}  // namespace landmark_loop_closure
