#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace landmark_loop_closure {

/// How many keyframe ids apart two keyframes are.
inline uint64_t idGap(uint64_t a, uint64_t b) { return a > b ? a - b : b - a; }

/// One place by the map's ids: the same session and at most `window` ids apart (the acceptance
/// stages' place_window).
inline bool sameIdPlace(uint64_t id_a, uint32_t session_a, uint64_t id_b, uint32_t session_b,
                        uint64_t window) {
  return session_a == session_b && idGap(id_a, id_b) <= window;
}

/// A shortlisted candidate as the distinctiveness test sees it.
struct ShortlistEntry {
  uint64_t id = 0;
  uint32_t session = 0;
  double score = 0.0;
};

/// How much each candidate stands out from the other places of the query's shortlist: its score
/// over the best score of a candidate that is another place, a place-level ratio test. Where the
/// view is ambiguous (a forest, a corridor, a dark street) the query resembles several places about
/// equally, and the best of them is a guess; a place the query truly revisits scores clearly above
/// the rest.
///
/// Another place: a candidate of the same session, more than `window` ids away, that
/// `could_be_same_place` (e.g. the odometry: both keyframes within its drift of each other, as on
/// the laps of one run) does not pair with it. Candidates of other sessions are not compared: a
/// place mapped in two sessions is not ambiguous. Without another place in the shortlist the
/// lowest shortlist score stands in (every other place scored at most that). A candidate with a
/// score above 0 over a competitor at or below 0 gets infinity; a score at or below 0 gets 0.
/// Returns one ratio per entry, in order.
std::vector<double> placeRatios(
    const std::vector<ShortlistEntry>& shortlist, uint64_t window,
    const std::function<bool(size_t a, size_t b)>& could_be_same_place = {});

}  // namespace landmark_loop_closure
