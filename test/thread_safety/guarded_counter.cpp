// Compiled by refuses_violations.sh with clang's -Wthread-safety: as written it must compile;
// with each VIOLATION_* defined it must not (the analysis sees what thread_annotations.h says).
#include <atomic>
#include <condition_variable>

#include "landmark_loop_closure/common/thread_annotations.h"

namespace landmark_loop_closure {

class GuardedCounter {
 public:
  void add() EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    ++count_;
    changed_.notify_all();
  }
  /// Waits behind the writers: a read-only handler must not.
  int waitForAtLeast(int wanted) EXCLUDES(mutex_, read_only_handler) {
    MutexLock lock(mutex_);
    while (count_ < wanted) lock.wait(changed_);
    return count_;
  }
  bool tryAdd() EXCLUDES(mutex_) {
    if (!mutex_.try_lock()) return false;
    MutexLock lock(mutex_, std::adopt_lock);
    addLocked();
    return true;
  }
  int read() EXCLUDES(mutex_) {
#if defined(VIOLATION_UNLOCKED_READ)
    return count_;
#elif defined(VIOLATION_REQUIRES_NOT_HELD)
    addLocked();
    return 0;
#elif defined(VIOLATION_READ_AFTER_UNLOCK)
    MutexLock lock(mutex_);
    lock.unlock();
    return count_;
#else
    MutexLock lock(mutex_);
    return count_;
#endif
  }
  /// A read-only handler: what it reads, it reads without waiting.
  int readOnly() EXCLUDES(mutex_) {
    RoleScope reading(read_only_handler);
#if defined(VIOLATION_READ_ONLY_WAITS)
    return waitForAtLeast(1);
#else
    return published_.load();
#endif
  }
  /// A callback the holder runs (through std::function, where the analysis cannot follow).
  void addFromCallback() {
#if !defined(VIOLATION_UNASSERTED_CALLBACK)
    mutex_.assertHeld();
#endif
    ++count_;
  }

 private:
  void addLocked() REQUIRES(mutex_) { ++count_; }

  Mutex mutex_;
  std::condition_variable changed_;
  int count_ GUARDED_BY(mutex_) = 0;
  std::atomic<int> published_{0};
};

}  // namespace landmark_loop_closure

int main() {
  landmark_loop_closure::GuardedCounter counter;
  counter.add();
  return counter.read() == 1 && counter.tryAdd() && counter.waitForAtLeast(2) == 2 &&
                 counter.readOnly() == 0
             ? 0
             : 1;
}
