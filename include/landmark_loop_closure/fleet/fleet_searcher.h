// Own keyframes' rows searched in other robots' maps on a thread of its own (issue 81): the
// detector's worker hands a row over and goes on, so that its time per keyframe does not grow
// with the fleet. At most `max_waiting` rows wait; past it the oldest is dropped and counted
// (the newest keyframes are the likeliest still to be worth a fetch).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <thread>

#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/fleet/fleet_matcher.h"

namespace landmark_loop_closure {

class FleetSearcher {
 public:
  /// An own keyframe's row waiting to be searched.
  struct Search {
    SharedKeyframe row;
    uint64_t map_id = 0;         ///< The own map it was announced in.
    std::string odometry_frame;  ///< Its odometry frame.
  };
  /// The searcher's thread, after each search: its candidate (if any) and how long it took.
  using Searched =
      std::function<void(const Search&, std::optional<FleetCandidate>, double milliseconds)>;
  /// The searcher's thread: a search or `searched` threw; the next row is taken.
  using Failed = std::function<void(const Search&, const std::string& what)>;

  /// `matcher` is shared with whoever adds rows to it, all of them under `matcher_mutex`.
  FleetSearcher(FleetMatcher& matcher, Mutex& matcher_mutex, size_t max_waiting, Searched searched,
                Failed failed = nullptr);
  ~FleetSearcher();
  FleetSearcher(const FleetSearcher&) = delete;
  FleetSearcher& operator=(const FleetSearcher&) = delete;

  /// Any thread: queues `search`; never waits for a search.
  void hand(Search search);
  /// Waits until every row handed over so far has been searched (benchmarks, tests).
  void drain();
  /// Ends the thread; rows still waiting are not searched.
  void stop();

  uint64_t dropped() const { return dropped_.load(); }
  uint64_t searched() const { return searched_.load(); }
  double lastMilliseconds() const { return last_ms_.load(); }
  double maxMilliseconds() const { return max_ms_.load(); }

 private:
  void run();

  Mutex& matcher_mutex_;
  FleetMatcher& matcher_ GUARDED_BY(matcher_mutex_);
  const size_t max_waiting_;
  Searched on_searched_;
  Failed on_failed_;

  Mutex mutex_;
  std::condition_variable ready_;
  std::condition_variable idle_;
  std::deque<Search> waiting_ GUARDED_BY(mutex_);
  bool searching_ GUARDED_BY(mutex_) = false;
  bool stopping_ GUARDED_BY(mutex_) = false;
  std::thread thread_;

  std::atomic<uint64_t> dropped_{0};
  std::atomic<uint64_t> searched_{0};
  std::atomic<double> last_ms_{0.0};
  std::atomic<double> max_ms_{0.0};
};

}  // namespace landmark_loop_closure
