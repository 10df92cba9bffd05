// What each lock guards, said so that the compiler checks it: Clang's thread-safety attributes
// (-Wthread-safety; scripts/thread_safety.sh builds the libraries and the nodes with it), and a
// mutex and a lock that carry them, since libstdc++'s std::mutex carries none. Other compilers
// see plain std::mutex and std::unique_lock.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>

#if defined(__clang__)
#define LLC_THREAD_ATTRIBUTE(x) __attribute__((x))
#else
#define LLC_THREAD_ATTRIBUTE(x)
#endif

#define CAPABILITY(x) LLC_THREAD_ATTRIBUTE(capability(x))
#define SCOPED_CAPABILITY LLC_THREAD_ATTRIBUTE(scoped_lockable)
/// A member read or written only with this mutex held.
#define GUARDED_BY(x) LLC_THREAD_ATTRIBUTE(guarded_by(x))
/// A pointer whose target is read or written only with this mutex held.
#define PT_GUARDED_BY(x) LLC_THREAD_ATTRIBUTE(pt_guarded_by(x))
/// A function called only with these mutexes held.
#define REQUIRES(...) LLC_THREAD_ATTRIBUTE(requires_capability(__VA_ARGS__))
/// A function called only with these mutexes free (it takes them itself, or must never wait).
#define EXCLUDES(...) LLC_THREAD_ATTRIBUTE(locks_excluded(__VA_ARGS__))
#define ACQUIRE(...) LLC_THREAD_ATTRIBUTE(acquire_capability(__VA_ARGS__))
#define RELEASE(...) LLC_THREAD_ATTRIBUTE(release_capability(__VA_ARGS__))
#define TRY_ACQUIRE(...) LLC_THREAD_ATTRIBUTE(try_acquire_capability(__VA_ARGS__))
#define ACQUIRED_AFTER(...) LLC_THREAD_ATTRIBUTE(acquired_after(__VA_ARGS__))
#define RETURN_CAPABILITY(x) LLC_THREAD_ATTRIBUTE(lock_returned(x))
/// Opts one function out, for a reason its comment gives.
#define NO_THREAD_SAFETY_ANALYSIS LLC_THREAD_ATTRIBUTE(no_thread_safety_analysis)

namespace landmark_loop_closure {

/// std::mutex, annotated.
class CAPABILITY("mutex") Mutex {
 public:
  void lock() ACQUIRE() { mutex_.lock(); }
  void unlock() RELEASE() { mutex_.unlock(); }
  bool try_lock() TRY_ACQUIRE(true) { return mutex_.try_lock(); }

 private:
  friend class MutexLock;
  std::mutex mutex_;
};

/// Holds a Mutex for its scope (std::unique_lock, annotated); may be released and taken again
/// within it, and waits on a condition variable with the mutex held before and after.
class SCOPED_CAPABILITY MutexLock {
 public:
  explicit MutexLock(Mutex& mutex) ACQUIRE(mutex) : lock_(mutex.mutex_) {}
  /// Takes over a mutex this thread locked already (Mutex::try_lock).
  MutexLock(Mutex& mutex, std::adopt_lock_t) REQUIRES(mutex)
      : lock_(mutex.mutex_, std::adopt_lock) {}
  ~MutexLock() RELEASE() {}
  MutexLock(const MutexLock&) = delete;
  MutexLock& operator=(const MutexLock&) = delete;

  void unlock() RELEASE() { lock_.unlock(); }
  void lock() ACQUIRE() { lock_.lock(); }

  /// One wait (it may wake spuriously: callers loop on their condition, which the analysis then
  /// sees read with the mutex held, as a predicate lambda it would not).
  void wait(std::condition_variable& condition) { condition.wait(lock_); }
  /// One wait of at most `timeout`; false when it timed out.
  template <class Rep, class Period>
  bool waitFor(std::condition_variable& condition,
               const std::chrono::duration<Rep, Period>& timeout) {
    return condition.wait_for(lock_, timeout) == std::cv_status::no_timeout;
  }
  template <class Clock, class Duration>
  bool waitUntil(std::condition_variable& condition,
                 const std::chrono::time_point<Clock, Duration>& deadline) {
    return condition.wait_until(lock_, deadline) == std::cv_status::no_timeout;
  }

 private:
  std::unique_lock<std::mutex> lock_;
};

}  // namespace landmark_loop_closure
