// How often other processes may ask this node for work: a token bucket per sender, and one for
// all senders together, so that a caller inventing a new name per request gains nothing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>

namespace landmark_loop_closure {

class RequestRate {
 public:
  /// Each sender may make `per_sender_per_s` requests a second (bursts of as many), all senders
  /// together `total_per_s`; at most `max_senders` are remembered (the longest idle is
  /// forgotten first, and a forgotten sender starts with a full bucket, within the total).
  RequestRate(double per_sender_per_s, double total_per_s, size_t max_senders = 64);

  /// Whether `sender` may be answered at `now_s` (seconds, any steady clock); takes one request
  /// from its bucket and the total's when so.
  bool allow(const std::string& sender, double now_s);

  size_t senders() const { return senders_.size(); }
  uint64_t refused() const { return refused_; }

 private:
  struct Bucket {
    double tokens = 0.0;
    double last_s = 0.0;
  };
  static void refill(Bucket* bucket, double rate_per_s, double now_s);

  double per_sender_per_s_;
  double total_per_s_;
  size_t max_senders_;
  Bucket total_;
  std::map<std::string, Bucket> senders_;
  uint64_t refused_ = 0;
};

}  // namespace landmark_loop_closure
