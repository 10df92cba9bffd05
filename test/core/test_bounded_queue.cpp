#include <thread>

#include <gtest/gtest.h>

#include "landmark_loop_closure/bounded_queue.h"

using namespace landmark_loop_closure;

TEST(BoundedQueue, FifoWithinCapacity) {
  BoundedQueue<int> queue(3);
  for (int i = 0; i < 3; ++i) EXPECT_FALSE(queue.push(i, false).dropped);
  EXPECT_EQ(*queue.pop(), 0);
  EXPECT_EQ(*queue.pop(), 1);
  EXPECT_EQ(*queue.pop(), 2);
}

TEST(BoundedQueue, FullQueueDropsTheOldestDroppableFirst) {
  BoundedQueue<int> queue(3);
  queue.push(1, false);
  queue.push(2, true);
  queue.push(3, false);
  const auto result = queue.push(4, false);
  EXPECT_TRUE(result.dropped);
  EXPECT_TRUE(result.dropped_droppable);
  EXPECT_EQ(*queue.pop(), 1);
  EXPECT_EQ(*queue.pop(), 3);
  EXPECT_EQ(*queue.pop(), 4);
}

TEST(BoundedQueue, WithNothingDroppableTheOldestGoes) {
  BoundedQueue<int> queue(2);
  queue.push(1, false);
  queue.push(2, false);
  const auto result = queue.push(3, false);
  EXPECT_TRUE(result.dropped);
  EXPECT_FALSE(result.dropped_droppable);
  EXPECT_EQ(queue.size(), 2u);
  EXPECT_EQ(*queue.pop(), 2);
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
  for (int i = 0; i < 1000; ++i) dropped += queue.push(i, true).dropped ? 1 : 0;
  EXPECT_EQ(dropped, 996);
  EXPECT_EQ(*queue.pop(), 996);
}
