#include "evidence_channel.h"

#include <algorithm>
#include <cmath>

#include <ros/connection.h>
#include <ros/serialization.h>
#include <ros/service_manager.h>
#include <ros/service_traits.h>

namespace landmark_loop_closure {

EvidenceChannel::EvidenceChannel(std::string service, double timeout_s, size_t max_answer_bytes)
    : service_(std::move(service)), timeout_(timeout_s), max_answer_bytes_(max_answer_bytes) {
  caller_ = std::thread([this] { callLoop(); });
  watchdog_ = std::thread([this] { watchLoop(); });
}

EvidenceChannel::~EvidenceChannel() { stop(); }

EvidenceChannel::Offer EvidenceChannel::offer(const FleetEvidenceRequest& request,
                                              Continuation then) {
  {
    MutexLock lock(mutex_);
    if (stopping_) return Offer::kStopped;
    if (busy_ || next_) return Offer::kBusy;
    if (std::chrono::steady_clock::now() < next_allowed_) return Offer::kBackingOff;
    next_.emplace(request, std::move(then));
  }
  wake_.notify_all();
  return Offer::kHanded;
}

void EvidenceChannel::noteAnswer(bool usable) {
  const double longest_wait = 8.0 * timeout_.count();
  MutexLock lock(mutex_);
  if (usable) {
    unusable_in_row_ = 0;
    next_allowed_ = std::chrono::steady_clock::time_point();
    return;
  }
  unusable_in_row_ = std::min(unusable_in_row_ + 1, 16);
  const double wait =
      std::min(timeout_.count() * std::ldexp(1.0, unusable_in_row_ - 1), longest_wait);
  next_allowed_ = std::chrono::steady_clock::now() +
                  std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                      std::chrono::duration<double>(wait));
}

void EvidenceChannel::stop() {
  ros::ServiceServerLinkPtr link;
  {
    MutexLock lock(mutex_);
    if (stopping_ && !caller_.joinable()) return;
    stopping_ = true;
    next_.reset();
    if (calling_) link = link_;
  }
  wake_.notify_all();
  if (link) link->getConnection()->drop(ros::Connection::Destructing);
  if (caller_.joinable()) caller_.join();
  if (watchdog_.joinable()) watchdog_.join();
}

uint64_t EvidenceChannel::timeouts() const {
  MutexLock lock(mutex_);
  return timeouts_;
}

void EvidenceChannel::callLoop() {
  for (;;) {
    std::pair<FleetEvidenceRequest, Continuation> job;
    {
      MutexLock lock(mutex_);
      while (!stopping_ && !next_.has_value()) lock.wait(wake_);
      if (stopping_) return;
      job = std::move(*next_);
      next_.reset();
      busy_ = true;
    }
    const Answer answer = call(job.first);
    if (job.second) job.second(answer);
    MutexLock lock(mutex_);
    busy_ = false;
  }
}

EvidenceChannel::Answer EvidenceChannel::call(const FleetEvidenceRequest& request) {
  namespace ser = ros::serialization;
  const std::string md5 = ros::service_traits::md5sum<FleetEvidence>();
  Answer answer;
  ros::ServiceServerLinkPtr link;
  {
    MutexLock lock(mutex_);
    link = link_;
  }
  if (!link || !link->isValid()) {
    // Looks the service up at the master and connects; the call below waits for the handshake.
    link = ros::ServiceManager::instance()->createServiceServerLink(service_, true, md5, md5,
                                                                    ros::M_string());
    if (!link) {
      answer.problem = "the service is not advertised (is the peer's detector running?)";
      return answer;
    }
  }
  uint64_t number = 0;
  {
    MutexLock lock(mutex_);
    if (stopping_) return answer;
    link_ = link;
    number = ++call_number_;
    calling_ = true;
    timed_out_ = false;
    deadline_ = std::chrono::steady_clock::now() +
                std::chrono::duration_cast<std::chrono::steady_clock::duration>(timeout_);
  }
  wake_.notify_all();
  const ros::SerializedMessage serialized_request = ser::serializeMessage(request);
  ros::SerializedMessage serialized_answer;
  const bool ok = link->call(serialized_request, serialized_answer);
  bool timed_out = false;
  {
    MutexLock lock(mutex_);
    if (call_number_ == number) calling_ = false;
    timed_out = timed_out_;
    if (!ok && link_ == link) link_.reset();  // Connect again next time.
  }
  if (timed_out) {
    answer.problem = "no answer within advanced/fleet/fetch_timeout_s";
    return answer;
  }
  if (!ok) {
    answer.problem = "the service call failed (is the peer's detector running?)";
    return answer;
  }
  answer.bytes = serialized_answer.num_bytes;
  if (answer.bytes > max_answer_bytes_) {
    answer.problem = "an answer of " + std::to_string(answer.bytes) + " bytes, past the " +
                     std::to_string(max_answer_bytes_) + " that max_features keypoints and a " +
                     "thumbnail take";
    return answer;
  }
  FleetEvidenceResponse response;
  try {
    ser::deserializeMessage(serialized_answer, response);
  } catch (const std::exception& error) {
    answer.problem = std::string("the answer could not be read: ") + error.what();
    return answer;
  }
  answer.response = std::move(response);
  return answer;
}

void EvidenceChannel::watchLoop() {
  MutexLock lock(mutex_);
  while (!stopping_) {
    if (!calling_) {
      while (!stopping_ && !calling_) lock.wait(wake_);
      continue;
    }
    const uint64_t number = call_number_;
    const auto deadline = deadline_;
    const auto call_ended = [&]() REQUIRES(mutex_) {
      return stopping_ || !calling_ || call_number_ != number;
    };
    while (!call_ended() && lock.waitUntil(wake_, deadline)) {
    }
    if (call_ended()) continue;
    // Still out at its deadline: dropping the connection ends the wait in link->call().
    timed_out_ = true;
    ++timeouts_;
    ros::ServiceServerLinkPtr link = link_;
    link_.reset();
    lock.unlock();
    if (link) link->getConnection()->drop(ros::Connection::Destructing);
    lock.lock();
    // The caller sees calling_ cleared when its call returns.
    while (!call_ended()) lock.wait(wake_);
  }
}

}  // namespace landmark_loop_closure
