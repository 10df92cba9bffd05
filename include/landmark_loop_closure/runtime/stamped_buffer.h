#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <map>
#include <optional>
#include <utility>

#include "landmark_loop_closure/common/thread_annotations.h"

namespace landmark_loop_closure {

/// When waiting for an item near a stamp is worth it.
struct StampedWait {
  double slop_s = 0.05;     ///< An item matches when its stamp is this close.
  double max_wait_s = 0.2;  ///< Longest wait for a match that has not come yet.
  /// The stream counts as stopped when its newest item is this much older than the stamp asked
  /// for: waiting would only slow the caller down.
  double silence_s = 1.0;
};

/// Items of a side stream (depth images) by stamp, newest last, at most `capacity` kept. Producers
/// (subscriber callbacks) never wait; one consumer asks for the item nearest a stamp and waits a
/// bounded time for it while it may still come. A consumer that will ask late (a worker behind its
/// queue) says so with want(): the item nearest that stamp is then held for it, however many newer
/// items push it out of the window.
template <typename T>
class StampedBuffer {
 public:
  /// `max_wanted`: stamps held at once; the oldest is forgotten beyond it (a consumer that never
  /// asked, e.g. for a job it dropped, cannot pin items forever).
  explicit StampedBuffer(size_t capacity, size_t max_wanted = 16)
      : capacity_(capacity == 0 ? 1 : capacity), max_wanted_(max_wanted) {}

  void push(double stamp, T item) {
    {
      MutexLock lock(mutex_);
      for (auto& [wanted_stamp, held] : wanted_) hold(wanted_stamp, stamp, item, &held);
      items_.emplace_back(stamp, std::move(item));
      if (items_.size() > capacity_) items_.pop_front();
      ++pushes_;
      silent_ = false;
    }
    arrived_.notify_all();
  }

  /// Holds the item nearest `stamp` within `slop_s`, now and as items come, until nearest() is
  /// asked for that stamp.
  void want(double stamp, double slop_s) {
    MutexLock lock(mutex_);
    if (max_wanted_ == 0) return;
    Held& held = wanted_[stamp];
    held.slop_s = slop_s;
    for (const auto& [item_stamp, item] : items_) hold(stamp, item_stamp, item, &held);
    while (wanted_.size() > max_wanted_) wanted_.erase(wanted_.begin());
  }

  void setMaxWanted(size_t max_wanted) {
    MutexLock lock(mutex_);
    max_wanted_ = max_wanted;
    while (wanted_.size() > max_wanted_) wanted_.erase(wanted_.begin());
  }

  size_t wantedCount() const {
    MutexLock lock(mutex_);
    return wanted_.size();
  }

  /// The item nearest `stamp` within wait.slop_s. Waits up to wait.max_wait_s while none matches
  /// yet, no item newer than stamp + slop has come (the matching one would have come first), and
  /// the stream is alive: its newest item within wait.silence_s of the stamp or, when nothing
  /// came yet, `producers_present`. A wait that runs out with nothing at all arriving marks the
  /// stream silent (a publisher that never publishes): no later call waits until an item comes.
  std::optional<T> nearest(double stamp, const StampedWait& wait, bool producers_present) {
    const auto give_up = std::chrono::steady_clock::now() +
                         std::chrono::duration<double>(std::max(0.0, wait.max_wait_s));
    MutexLock lock(mutex_);
    const uint64_t pushes_before = pushes_;
    bool timed_out = false;
    while (true) {
      const T* best = nullptr;
      double best_gap = wait.slop_s;
      bool later_arrived = false;
      const auto held = wanted_.find(stamp);
      if (held != wanted_.end() && held->second.item) {
        best_gap = std::min(best_gap, held->second.gap);
        if (held->second.gap <= wait.slop_s) best = &*held->second.item;
        later_arrived |= held->second.later_arrived;
      }
      for (const auto& [item_stamp, item] : items_) {
        later_arrived |= item_stamp > stamp + wait.slop_s;
        const double gap = std::abs(item_stamp - stamp);
        if (gap <= best_gap) {
          best = &item;
          best_gap = gap;
        }
      }
      if (best != nullptr) {
        std::optional<T> found = *best;
        if (held != wanted_.end()) wanted_.erase(held);
        return found;
      }
      const bool alive =
          !silent_ &&
          (items_.empty() ? producers_present : items_.back().first + wait.silence_s > stamp);
      if (timed_out && pushes_ == pushes_before) silent_ = true;
      if (timed_out || later_arrived || !alive) {
        if (held != wanted_.end()) wanted_.erase(held);
        return std::nullopt;
      }
      // After a timeout the loop looks once more: an item may have come with it.
      timed_out = !lock.waitUntil(arrived_, give_up);
    }
  }

  /// Whether a wait ran out with nothing arriving and no item came since.
  bool silent() const {
    MutexLock lock(mutex_);
    return silent_;
  }

  size_t size() const {
    MutexLock lock(mutex_);
    return items_.size();
  }

 private:
  struct Held {
    double slop_s = 0.0;
    std::optional<T> item;
    double gap = 0.0;            ///< |item's stamp - wanted stamp|.
    bool later_arrived = false;  ///< An item newer than wanted + slop came: no better one will.
  };

  static void hold(double wanted_stamp, double item_stamp, const T& item, Held* held) {
    held->later_arrived |= item_stamp > wanted_stamp + held->slop_s;
    const double gap = std::abs(item_stamp - wanted_stamp);
    if (gap > held->slop_s || (held->item && gap > held->gap)) return;
    held->item = item;
    held->gap = gap;
  }

  const size_t capacity_;
  mutable Mutex mutex_;
  std::condition_variable arrived_;
  size_t max_wanted_ GUARDED_BY(mutex_);
  std::map<double, Held> wanted_ GUARDED_BY(mutex_);
  std::deque<std::pair<double, T>> items_ GUARDED_BY(mutex_);
  uint64_t pushes_ GUARDED_BY(mutex_) = 0;
  bool silent_ GUARDED_BY(mutex_) = false;
};

}  // namespace landmark_loop_closure
