// The evidence service's bound on what other processes may ask of it (issue 81): a sender past
// its rate is refused, one that waits is answered again, and inventing a name per request gains
// nothing over the bound on all senders together.
#include <string>

#include <gtest/gtest.h>

#include "landmark_loop_closure/fleet/request_rate.h"

namespace landmark_loop_closure {
namespace {

int allowedOf(RequestRate& rate, const std::string& sender, int requests, double now_s) {
  int allowed = 0;
  for (int i = 0; i < requests; ++i) allowed += rate.allow(sender, now_s) ? 1 : 0;
  return allowed;
}

TEST(RequestRate, ASenderGetsItsBurstThenItsRate) {
  RequestRate rate(10.0, 1000.0);
  EXPECT_EQ(allowedOf(rate, "/robot_b/loop_closure", 50, 100.0), 10);
  EXPECT_EQ(rate.refused(), 40u);
  // Half a second later: five more, not a full bucket.
  EXPECT_EQ(allowedOf(rate, "/robot_b/loop_closure", 50, 100.5), 5);
  // A second's wait refills at most one second's requests.
  EXPECT_EQ(allowedOf(rate, "/robot_b/loop_closure", 50, 200.0), 10);
}

TEST(RequestRate, OneSenderDoesNotTakeAnothersShare) {
  RequestRate rate(10.0, 1000.0);
  EXPECT_EQ(allowedOf(rate, "/rogue", 1000, 5.0), 10);
  EXPECT_EQ(allowedOf(rate, "/robot_b/loop_closure", 10, 5.0), 10);
}

TEST(RequestRate, InventedNamesAreBoundedByTheTotal) {
  RequestRate rate(10.0, 40.0, 8);
  int allowed = 0;
  for (int i = 0; i < 10000; ++i) allowed += rate.allow("/rogue_" + std::to_string(i), 1.0) ? 1 : 0;
  EXPECT_EQ(allowed, 40);
  EXPECT_LE(rate.senders(), 8u) << "senders remembered are bounded";
  // A second later the total allows 40 again, whoever asks.
  EXPECT_EQ(allowedOf(rate, "/robot_b/loop_closure", 10, 2.0), 10);
}

TEST(RequestRate, AClockGoingBackRefillsNothing) {
  RequestRate rate(5.0, 100.0);
  EXPECT_EQ(allowedOf(rate, "a", 10, 50.0), 5);
  EXPECT_EQ(allowedOf(rate, "a", 10, 10.0), 0);
  EXPECT_EQ(allowedOf(rate, "a", 10, 50.5), 2);
}

}  // namespace
}  // namespace landmark_loop_closure
