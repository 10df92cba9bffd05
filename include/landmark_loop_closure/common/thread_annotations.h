// What each lock guards, said so that the compiler checks it: Clang's thread-safety attributes
// (-Wthread-safety; scripts/thread_safety.sh builds the libraries and the nodes with it), and a
// mutex and a lock that carry them, since libstdc++'s std::mutex carries none. Other compilers
// see plain std::mutex and std::unique_lock.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stdexcept>
#include <thread>

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
/// The function checks, at run time, that the calling thread holds these.
#define ASSERT_CAPABILITY(x) LLC_THREAD_ATTRIBUTE(assert_capability(x))
/// Opts one function out, for a reason its comment gives.
#define NO_THREAD_SAFETY_ANALYSIS LLC_THREAD_ATTRIBUTE(no_thread_safety_analysis)

namespace landmark_loop_closure {

/// std::mutex, annotated, and knowing which thread holds it (assertHeld()).
class CAPABILITY("mutex") Mutex {
 public:
  void lock() ACQUIRE() {
    mutex_.lock();
    markHeld();
  }
  void unlock() RELEASE() {
    markFree();
    mutex_.unlock();
  }
  bool try_lock() TRY_ACQUIRE(true) {
    if (!mutex_.try_lock()) return false;
    markHeld();
    return true;
  }
  /// For code the holder runs where the analysis cannot follow the lock (a callback the holder
  /// invokes through std::function): says so to the analysis, and throws std::logic_error when
  /// the calling thread does not hold the mutex.
  void assertHeld() const ASSERT_CAPABILITY(this) {
    if (owner_.load(std::memory_order_relaxed) != std::this_thread::get_id()) {
      throw std::logic_error("a mutex-guarded member used without its mutex held");
    }
  }

 private:
  friend class MutexLock;
  void markHeld() { owner_.store(std::this_thread::get_id(), std::memory_order_relaxed); }
  void markFree() { owner_.store(std::thread::id(), std::memory_order_relaxed); }

  std::mutex mutex_;
  std::atomic<std::thread::id> owner_{};
};

/// Holds a Mutex for its scope (std::unique_lock, annotated); may be released and taken again
/// within it, and waits on a condition variable with the mutex held before and after.
class SCOPED_CAPABILITY MutexLock {
 public:
  explicit MutexLock(Mutex& mutex) ACQUIRE(mutex) : mutex_(mutex) { mutex_.lock(); }
  /// Takes over a mutex this thread locked already (Mutex::try_lock).
  MutexLock(Mutex& mutex, std::adopt_lock_t) REQUIRES(mutex) : mutex_(mutex), held_(true) {}
  ~MutexLock() RELEASE() {
    if (held_) mutex_.unlock();
  }
  MutexLock(const MutexLock&) = delete;
  MutexLock& operator=(const MutexLock&) = delete;

  void unlock() RELEASE() {
    held_ = false;
    mutex_.unlock();
  }
  void lock() ACQUIRE() {
    mutex_.lock();
    held_ = true;
  }

  /// One wait (it may wake spuriously: callers loop on their condition, which the analysis then
  /// sees read with the mutex held, as a predicate lambda it would not).
  void wait(std::condition_variable& condition) {
    waiting([&](std::unique_lock<std::mutex>& lock) {
      condition.wait(lock);
      return true;
    });
  }
  /// One wait of at most `timeout`; false when it timed out.
  template <class Rep, class Period>
  bool waitFor(std::condition_variable& condition,
               const std::chrono::duration<Rep, Period>& timeout) {
    return waiting([&](std::unique_lock<std::mutex>& lock) {
      return condition.wait_for(lock, timeout) == std::cv_status::no_timeout;
    });
  }
  template <class Clock, class Duration>
  bool waitUntil(std::condition_variable& condition,
                 const std::chrono::time_point<Clock, Duration>& deadline) {
    return waiting([&](std::unique_lock<std::mutex>& lock) {
      return condition.wait_until(lock, deadline) == std::cv_status::no_timeout;
    });
  }

 private:
  /// The condition variable's wait on the held std::mutex, the holder forgotten meanwhile.
  template <class Wait>
  bool waiting(Wait&& wait) {
    std::unique_lock<std::mutex> lock(mutex_.mutex_, std::adopt_lock);
    mutex_.markFree();
    const bool woken = wait(lock);
    mutex_.markHeld();
    lock.release();
    return woken;
  }

  Mutex& mutex_;
  bool held_ = true;
};

/// A role the analysis tracks like a lock, though nothing is locked: what holds it promises not to
/// wait for the work it must never wait behind. Functions that wait for that work say
/// EXCLUDES(the role), so a call from a holder does not compile.
class CAPABILITY("role") Role {
 public:
  void enter() ACQUIRE() {}
  void leave() RELEASE() {}
};

/// Takes a role for its scope.
class SCOPED_CAPABILITY RoleScope {
 public:
  explicit RoleScope(Role& role) ACQUIRE(role) : role_(role) { role_.enter(); }
  ~RoleScope() RELEASE() { role_.leave(); }
  RoleScope(const RoleScope&) = delete;
  RoleScope& operator=(const RoleScope&) = delete;

 private:
  Role& role_;
};

/// Held by a handler that only reads (the node's diagnostics): it may take brief locks, but
/// never the detector's, which the worker holds while it describes, searches and saves
/// (DetectorRuntime's functions that take it exclude this role).
inline Role read_only_handler;

}  // namespace landmark_loop_closure
