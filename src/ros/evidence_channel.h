// One peer's evidence service, asked from one thread of this node over one persistent
// connection: at most one request out at a time, and a request unanswered within its timeout is
// ended by dropping the connection (the next request connects again). A peer whose answers are
// of no use (none, too large, malformed, "not found") is asked less and less often, down to one
// request in 8 fetch timeouts, until one is of use again. A peer that never answers holds this
// channel's two threads, never more, and nothing else of the node.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <thread>

#include <ros/service_server_link.h>

#include "landmark_loop_closure/FleetEvidence.h"
#include "landmark_loop_closure/common/thread_annotations.h"

namespace landmark_loop_closure {

class EvidenceChannel {
 public:
  /// What came back for one request.
  struct Answer {
    std::optional<FleetEvidenceResponse> response;  ///< Empty: no usable answer (`problem`).
    std::string problem;
    size_t bytes = 0;  ///< The answer's size on the wire (0 without one).
  };
  /// Runs on the channel's thread once the request was answered or given up; the next request
  /// is taken after it returns.
  using Continuation = std::function<void(const Answer&)>;

  /// `service`: the resolved name of the peer's ~keyframe_evidence. An answer of more than
  /// `max_answer_bytes` is refused before it is decoded.
  EvidenceChannel(std::string service, double timeout_s, size_t max_answer_bytes);
  ~EvidenceChannel();
  EvidenceChannel(const EvidenceChannel&) = delete;
  EvidenceChannel& operator=(const EvidenceChannel&) = delete;

  enum class Offer { kHanded, kBusy, kBackingOff, kStopped };
  /// Hands `request` to the channel; nothing is asked while an earlier one is still out (or being
  /// checked), while the channel backs off after answers of no use, or once it stopped.
  Offer offer(const FleetEvidenceRequest& request, Continuation then);
  /// The continuation's verdict on the answer it got: of use (a peer's proper answer, whatever
  /// the check then decides) or not. Unusable answers in a row double the wait before the next
  /// request, from fetch_timeout_s up to 8 times it.
  void noteAnswer(bool usable);
  /// Ends a request that is out and joins the threads; offer() refuses from then on.
  void stop();

  const std::string& service() const { return service_; }
  uint64_t timeouts() const;

 private:
  void callLoop();
  void watchLoop();
  Answer call(const FleetEvidenceRequest& request);

  const std::string service_;
  const std::chrono::duration<double> timeout_;
  const size_t max_answer_bytes_;

  mutable Mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ GUARDED_BY(mutex_) = false;
  /// A request was taken and its continuation has not returned.
  bool busy_ GUARDED_BY(mutex_) = false;
  std::optional<std::pair<FleetEvidenceRequest, Continuation>> next_ GUARDED_BY(mutex_);
  /// The persistent connection; reset when it drops.
  ros::ServiceServerLinkPtr link_ GUARDED_BY(mutex_);
  /// Of the call out (`calling_`), so a late drop hits no other.
  uint64_t call_number_ GUARDED_BY(mutex_) = 0;
  bool calling_ GUARDED_BY(mutex_) = false;
  bool timed_out_ GUARDED_BY(mutex_) = false;  ///< The call out was ended by the watchdog.
  std::chrono::steady_clock::time_point deadline_ GUARDED_BY(mutex_);
  uint64_t timeouts_ GUARDED_BY(mutex_) = 0;
  int unusable_in_row_ GUARDED_BY(mutex_) = 0;
  /// Backing off until then.
  std::chrono::steady_clock::time_point next_allowed_ GUARDED_BY(mutex_);
  std::thread caller_;
  std::thread watchdog_;
};

}  // namespace landmark_loop_closure
