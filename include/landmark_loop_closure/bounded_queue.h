#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>

namespace landmark_loop_closure {

/// A bounded FIFO between a producer that must never wait (a subscriber callback) and one
/// consumer thread. When full, push() drops the oldest droppable item, or the oldest item when
/// none is droppable, and reports it, so the producer always returns at once.
template <typename T>
class BoundedQueue {
 public:
  explicit BoundedQueue(size_t capacity) : capacity_(capacity == 0 ? 1 : capacity) {}

  struct PushResult {
    bool dropped = false;            ///< An older item was dropped to make room.
    bool dropped_droppable = false;  ///< ...and it was a droppable one.
  };

  PushResult push(T item, bool droppable) {
    PushResult result;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (items_.size() >= capacity_) {
        auto victim = items_.begin();
        for (auto it = items_.begin(); it != items_.end(); ++it) {
          if (it->droppable) {
            victim = it;
            break;
          }
        }
        result.dropped = true;
        result.dropped_droppable = victim->droppable;
        items_.erase(victim);
      }
      items_.push_back(Entry{std::move(item), droppable});
    }
    ready_.notify_one();
    return result;
  }

  /// Blocks until an item arrives or close() is called; nullopt once closed.
  std::optional<T> pop() {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [this] { return closed_ || !items_.empty(); });
    if (closed_) return std::nullopt;
    T item = std::move(items_.front().value);
    items_.pop_front();
    return item;
  }

  /// Wakes the consumer; pop() returns nullopt from now on.
  void close() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closed_ = true;
    }
    ready_.notify_all();
  }

  size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_.size();
  }
  size_t capacity() const { return capacity_; }

 private:
  struct Entry {
    T value;
    bool droppable;
  };
  const size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::deque<Entry> items_;
  bool closed_ = false;
};

}  // namespace landmark_loop_closure
