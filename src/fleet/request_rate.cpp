#include "landmark_loop_closure/fleet/request_rate.h"

#include <algorithm>

namespace landmark_loop_closure {

RequestRate::RequestRate(double per_sender_per_s, double total_per_s, size_t max_senders)
    : per_sender_per_s_(std::max(per_sender_per_s, 0.0)),
      total_per_s_(std::max(total_per_s, 0.0)),
      max_senders_(std::max<size_t>(max_senders, 1)) {
  total_.tokens = total_per_s_;
  total_.last_s = -1.0;  // Full at the first request, whatever its clock says.
}

void RequestRate::refill(Bucket* bucket, double rate_per_s, double now_s) {
  // A clock that went back refills nothing; a bucket holds at most a second's requests.
  const double elapsed = std::max(now_s - bucket->last_s, 0.0);
  bucket->tokens = std::min(bucket->tokens + elapsed * rate_per_s, rate_per_s);
  bucket->last_s = std::max(bucket->last_s, now_s);
}

bool RequestRate::allow(const std::string& sender, double now_s) {
  if (total_.last_s < 0.0) total_.last_s = now_s;
  refill(&total_, total_per_s_, now_s);
  auto found = senders_.find(sender);
  if (found == senders_.end()) {
    if (senders_.size() >= max_senders_) {
      const auto idlest = std::min_element(
          senders_.begin(), senders_.end(),
          [](const auto& a, const auto& b) { return a.second.last_s < b.second.last_s; });
      senders_.erase(idlest);
    }
    found = senders_.emplace(sender, Bucket{per_sender_per_s_, now_s}).first;
  }
  Bucket& own = found->second;
  refill(&own, per_sender_per_s_, now_s);
  if (own.tokens < 1.0 || total_.tokens < 1.0) {
    ++refused_;
    return false;
  }
  own.tokens -= 1.0;
  total_.tokens -= 1.0;
  return true;
}

}  // namespace landmark_loop_closure
