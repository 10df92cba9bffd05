#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <optional>

#include "landmark_loop_closure/common/thread_annotations.h"

namespace landmark_loop_closure {

/// A bounded FIFO between a producer that must never wait (a subscriber callback) and one
/// consumer thread. When full, push() drops the oldest item and says so, so the producer always
/// returns at once and the consumer works on the freshest data.
template <typename T>
class BoundedQueue {
 public:
  explicit BoundedQueue(size_t capacity) : capacity_(capacity == 0 ? 1 : capacity) {}

  /// Returns true when the oldest item was dropped to make room.
  bool push(T item) {
    bool dropped = false;
    {
      MutexLock lock(mutex_);
      if (items_.size() >= capacity_) {
        items_.pop_front();
        dropped = true;
      }
      items_.push_back(std::move(item));
    }
    ready_.notify_one();
    return dropped;
  }

  /// Blocks until an item arrives or close() is called; nullopt once closed.
  std::optional<T> pop() {
    MutexLock lock(mutex_);
    while (!closed_ && items_.empty()) lock.wait(ready_);
    if (closed_) return std::nullopt;
    T item = std::move(items_.front());
    items_.pop_front();
    return item;
  }

  /// Wakes the consumer; pop() returns nullopt from now on.
  void close() {
    {
      MutexLock lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
  }

  size_t size() const {
    MutexLock lock(mutex_);
    return items_.size();
  }
  size_t capacity() const { return capacity_; }

 private:
  const size_t capacity_;
  mutable Mutex mutex_;
  std::condition_variable ready_;
  std::deque<T> items_ GUARDED_BY(mutex_);
  bool closed_ GUARDED_BY(mutex_) = false;
};

}  // namespace landmark_loop_closure
