#include "landmark_loop_closure/fleet/fleet_searcher.h"

#include <algorithm>
#include <chrono>
#include <exception>

namespace landmark_loop_closure {

FleetSearcher::FleetSearcher(FleetMatcher& matcher, Mutex& matcher_mutex, size_t max_waiting,
                             Searched searched, Failed failed)
    : matcher_mutex_(matcher_mutex),
      matcher_(matcher),
      max_waiting_(std::max<size_t>(max_waiting, 1)),
      on_searched_(std::move(searched)),
      on_failed_(std::move(failed)) {
  thread_ = std::thread([this] { run(); });
}

FleetSearcher::~FleetSearcher() { stop(); }

void FleetSearcher::hand(Search search) {
  {
    MutexLock lock(mutex_);
    if (stopping_) return;
    if (waiting_.size() >= max_waiting_) {
      waiting_.pop_front();
      ++dropped_;
    }
    waiting_.push_back(std::move(search));
  }
  ready_.notify_one();
}

void FleetSearcher::drain() {
  MutexLock lock(mutex_);
  while (!stopping_ && (!waiting_.empty() || searching_)) lock.wait(idle_);
}

void FleetSearcher::stop() {
  {
    MutexLock lock(mutex_);
    stopping_ = true;
    waiting_.clear();
  }
  ready_.notify_all();
  idle_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void FleetSearcher::run() {
  for (;;) {
    Search search;
    {
      MutexLock lock(mutex_);
      searching_ = false;
      idle_.notify_all();
      while (!stopping_ && waiting_.empty()) lock.wait(ready_);
      if (stopping_) return;
      search = std::move(waiting_.front());
      waiting_.pop_front();
      searching_ = true;
    }
    try {
      const auto start = std::chrono::steady_clock::now();
      std::optional<FleetCandidate> candidate;
      {
        MutexLock lock(matcher_mutex_);
        candidate = matcher_.query(search.row);
      }
      const double elapsed_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
      last_ms_ = elapsed_ms;
      if (elapsed_ms > max_ms_.load()) max_ms_ = elapsed_ms;
      ++searched_;
      if (candidate) candidate->query_map_id = search.map_id;
      if (on_searched_) on_searched_(search, std::move(candidate), elapsed_ms);
    } catch (const std::exception& error) {
      if (on_failed_) on_failed_(search, error.what());
    }
  }
}

}  // namespace landmark_loop_closure
