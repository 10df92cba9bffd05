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

/// Whether a candidate naming `match` for the keyframe `query` continues a loop that named
/// `last_match` for the keyframe `last_query` (ids of one run each): the next keyframe's match
/// within `index_window` of it, or, up to `across` keyframes later (refusals between), a match
/// not behind it and within index_window - 1 of where the same pace puts it (one id a keyframe):
/// the last loop may itself lie a frame off its place, and a pace window as wide as the chain's
/// let loops land 3 frames off on Gardens Point where a narrower one did not (bench/history.md).
/// A revisit keeps moving along the stretch it was confirmed on while a keyframe or two in a row
/// fail a check (night, a passing car).
inline bool continuesStretch(uint64_t last_query, uint64_t last_match, uint64_t query,
                             uint64_t match, int index_window, int across) {
  if (query <= last_query || query - last_query > static_cast<uint64_t>(across)) return false;
  const uint64_t steps = query - last_query;
  const uint64_t window = static_cast<uint64_t>(index_window);
  if (steps == 1) return idGap(match, last_match) <= window;
  const uint64_t pace_window = window > 0 ? window - 1 : 0;
  return match >= last_match && idGap(match, last_match + steps) <= pace_window;
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
