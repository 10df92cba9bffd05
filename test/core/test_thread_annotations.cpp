// The annotated mutex knows its holder: assertHeld() passes on the holding thread, before and
// after a wait, and throws anywhere else.
#include <chrono>
#include <condition_variable>
#include <stdexcept>
#include <thread>

#include <gtest/gtest.h>

#include "landmark_loop_closure/common/thread_annotations.h"

namespace landmark_loop_closure {
namespace {

TEST(Mutex, AssertHeldPassesOnlyOnTheHoldingThread) {
  Mutex mutex;
  EXPECT_THROW(mutex.assertHeld(), std::logic_error);
  {
    MutexLock lock(mutex);
    EXPECT_NO_THROW(mutex.assertHeld());
    bool thrown_elsewhere = false;
    std::thread other([&] {
      try {
        mutex.assertHeld();
      } catch (const std::logic_error&) {
        thrown_elsewhere = true;
      }
    });
    other.join();
    EXPECT_TRUE(thrown_elsewhere);
    lock.unlock();
    EXPECT_THROW(mutex.assertHeld(), std::logic_error);
    lock.lock();
    EXPECT_NO_THROW(mutex.assertHeld());
  }
  EXPECT_THROW(mutex.assertHeld(), std::logic_error);
  ASSERT_TRUE(mutex.try_lock());
  EXPECT_NO_THROW(mutex.assertHeld());
  MutexLock adopted(mutex, std::adopt_lock);
  EXPECT_NO_THROW(mutex.assertHeld());
}

TEST(Mutex, AWaitGivesTheMutexToOthersAndBack) {
  Mutex mutex;
  std::condition_variable changed;
  bool ready = false;
  bool other_held = false;
  std::thread other([&] {
    MutexLock lock(mutex);
    other_held = true;
    try {
      mutex.assertHeld();
    } catch (const std::logic_error&) {
      other_held = false;
    }
    ready = true;
    changed.notify_all();
  });
  {
    MutexLock lock(mutex);
    while (!ready) lock.waitFor(changed, std::chrono::milliseconds(50));
    EXPECT_TRUE(other_held) << "the other thread held it while this one waited";
    EXPECT_NO_THROW(mutex.assertHeld()) << "held again after the wait";
  }
  other.join();
}

}  // namespace
}  // namespace landmark_loop_closure
