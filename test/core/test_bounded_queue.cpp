#include <thread>

#include <gtest/gtest.h>

#include "landmark_loop_closure/runtime/bounded_queue.h"

using namespace landmark_loop_closure;

TEST(BoundedQueue, FifoWithinCapacity) {
  BoundedQueue<int> queue(3);
  for (int i = 0; i < 3; ++i) EXPECT_FALSE(queue.push(i));
  EXPECT_EQ(*queue.pop(), 0);
  EXPECT_EQ(*queue.pop(), 1);
  EXPECT_EQ(*queue.pop(), 2);
}

TEST(BoundedQueue, FullQueueDropsTheOldest) {
  BoundedQueue<int> queue(2);
  queue.push(1);
  queue.push(2);
  EXPECT_TRUE(queue.push(3));
  EXPECT_EQ(queue.size(), 2u);
  EXPECT_EQ(*queue.pop(), 2);
  EXPECT_EQ(*queue.pop(), 3);
}

TEST(BoundedQueue, CloseWakesABlockedConsumer) {
  BoundedQueue<int> queue(2);
  std::optional<int> popped = 42;
  std::thread consumer([&] { popped = queue.pop(); });
  queue.close();
  consumer.join();
  EXPECT_FALSE(popped.has_value());
}

TEST(BoundedQueue, ProducerNeverBlocksWhileConsumerIsBusy) {
  BoundedQueue<int> queue(4);
  int dropped = 0;
  for (int i = 0; i < 1000; ++i) dropped += queue.push(i) ? 1 : 0;
  EXPECT_EQ(dropped, 996);
  EXPECT_EQ(*queue.pop(), 996);
}

TEST(BoundedQueue, ZeroCapacityStillHoldsOne) {
  BoundedQueue<int> queue(0);
  EXPECT_EQ(queue.capacity(), 1u);
  queue.push(7);
  EXPECT_EQ(*queue.pop(), 7);
}
