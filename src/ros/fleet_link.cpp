#include "fleet_link.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "messages/ros_conversions.h"

namespace landmark_loop_closure {

namespace {

constexpr size_t kMaxWaitingFetches = 4;
constexpr double kWarningPeriod = 10.0;
constexpr double kSilenceCheckPeriod = 5.0;

/// A service call given up after `timeout_s`: the call goes on on a thread of its own, which
/// only touches this shared state, so a peer that never answers holds nothing of the node.
struct PendingCall {
  std::mutex mutex;
  std::condition_variable done_signal;
  bool done = false;
  bool ok = false;
  FleetEvidence service;
};

std::optional<FleetEvidence> callWithTimeout(const std::string& name,
                                             const FleetEvidence::Request& request,
                                             double timeout_s, std::string* problem) {
  auto call = std::make_shared<PendingCall>();
  call->service.request = request;
  std::thread([call, name] {
    FleetEvidence service;
    {
      std::lock_guard<std::mutex> lock(call->mutex);
      service.request = call->service.request;
    }
    const bool ok = ros::service::call(name, service);
    std::lock_guard<std::mutex> lock(call->mutex);
    call->ok = ok;
    call->service.response = service.response;
    call->done = true;
    call->done_signal.notify_all();
  }).detach();
  std::unique_lock<std::mutex> lock(call->mutex);
  if (!call->done_signal.wait_for(lock, std::chrono::duration<double>(timeout_s),
                                  [&] { return call->done; })) {
    *problem = "no answer within advanced/fleet/fetch_timeout_s";
    return std::nullopt;
  }
  if (!call->ok) {
    *problem = "the service call failed (is the peer's detector running?)";
    return std::nullopt;
  }
  return call->service;
}

}  // namespace

FleetLink::FleetLink(ros::NodeHandle node, ros::NodeHandle private_node,
                     const FleetOptions& options, const LoopDetector& detector, Hooks hooks)
    : node_(node),
      private_node_(private_node),
      options_(options),
      robot_(options.robot.empty() ? ros::this_node::getNamespace() : options.robot),
      hooks_(std::move(hooks)),
      matcher_(std::make_unique<FleetMatcher>(options_, detector.descriptorIdentity(),
                                              detector.database().globalDimension())),
      own_map_id_(detector.map().mapId()) {
  if (options_.share) {
    ros::AdvertiseOptions rows;
    rows.init<FleetKeyframe>(
        "shared_keyframes", 1000,
        [this](const ros::SingleSubscriberPublisher& subscriber) { sendBacklog(subscriber); });
    rows.callback_queue = &backlog_queue_;
    row_publisher_ = private_node_.advertise(rows);
    backlog_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &backlog_queue_);
    backlog_spinner_->start();
    ros::AdvertiseServiceOptions service;
    service.init<FleetEvidence::Request, FleetEvidence::Response>(
        "keyframe_evidence",
        [this](FleetEvidence::Request& request, FleetEvidence::Response& response) {
          return onEvidence(request, response);
        });
    service.callback_queue = &service_queue_;
    evidence_service_ = private_node_.advertiseService(service);
    service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
    service_spinner_->start();
  }
  for (const std::string& peer : options_.peerList()) {
    const std::string topic = ros::names::resolve(peer + "/shared_keyframes");
    row_subscribers_.push_back(node_.subscribe<FleetKeyframe>(
        topic, 1000, [this, peer](const FleetKeyframe::ConstPtr& msg) { onRow(peer, msg); }));
    ROS_INFO("fleet: keeping and searching the keyframes robot %s shares on %s", peer.c_str(),
             topic.c_str());
  }
  if (!options_.peerList().empty()) {
    fetch_thread_ = std::thread([this] { fetchLoop(); });
    silence_timer_ = node_.createWallTimer(
        ros::WallDuration(kSilenceCheckPeriod), [this](const ros::WallTimerEvent&) {
          std::lock_guard<std::mutex> lock(matcher_mutex_);
          for (const std::string& line : matcher_->checkSilence(ros::WallTime::now().toSec())) {
            ROS_WARN("fleet: %s", line.c_str());
          }
        });
  }
}

FleetLink::~FleetLink() { stop(); }

void FleetLink::stop() {
  backlog_stopping_ = true;
  if (backlog_spinner_) backlog_spinner_->stop();
  if (service_spinner_) service_spinner_->stop();
  {
    std::lock_guard<std::mutex> lock(fetch_mutex_);
    stopping_ = true;
  }
  fetch_ready_.notify_all();
  if (fetch_thread_.joinable()) fetch_thread_.join();
}

void FleetLink::onRow(const std::string& peer, const FleetKeyframe::ConstPtr& msg) {
  // Converted outside the lock; the matcher validates the row whole before it keeps anything.
  const SharedKeyframe row = sharedKeyframeFromMsg(*msg);
  RowVerdict verdict;
  {
    std::lock_guard<std::mutex> lock(matcher_mutex_);
    verdict = matcher_->addRowFrom(peer, row, ros::WallTime::now().toSec(), own_map_id_.load());
  }
  if (verdict.line.empty()) return;
  if (verdict.reason.empty()) {
    ROS_INFO("fleet: %s", verdict.line.c_str());
  } else if (refusals_.allow(peer + ":" + verdict.reason, ros::WallTime::now().toSec())) {
    // Keyed by the subscription and a fixed reason: names a sender invents add no keys.
    ROS_WARN("fleet: %s", verdict.line.c_str());
  }
}

void FleetLink::sendBacklog(const ros::SingleSubscriberPublisher& subscriber) {
  // Rows in chunks, the detector held for one chunk at a time; paced, because a publisher's queue
  // to one subscriber drops what the network cannot take. Rows shared meanwhile go out live too;
  // the peer keeps a row once.
  constexpr size_t kChunk = 50;
  const double chunk_period_s = static_cast<double>(kChunk) / options_.backlog_rows_per_s;
  std::string odometry_frame;
  {
    std::lock_guard<std::mutex> lock(odometry_frame_mutex_);
    odometry_frame = last_odometry_frame_;
  }
  size_t next = 0, sent = 0;
  bool more = true;
  const ros::WallTime start = ros::WallTime::now();
  while (more && !backlog_stopping_ && ros::ok()) {
    std::vector<FleetKeyframe> rows;
    hooks_.with_detector([&](LoopDetector& detector) {
      const KeyframeDatabase& database = detector.database();
      const size_t end = std::min(database.size(), next + kChunk);
      for (; next < end; ++next) {
        const uint64_t id = database.summary(next).id;
        if (detector.map().awaitingCommit(id)) continue;  // Shared live once committed.
        if (std::optional<SharedKeyframe> row =
                sharedKeyframeOf(detector, id, robot_, odometry_frame)) {
          rows.push_back(toFleetKeyframeMsg(*row));
        }
      }
      more = next < database.size();
    });
    for (const FleetKeyframe& row : rows) subscriber.publish(row);
    sent += rows.size();
    backlog_rows_sent_ += rows.size();
    if (more) ros::WallDuration(chunk_period_s).sleep();
  }
  if (sent > 0) {
    ROS_INFO(
        "fleet: %s subscribed to this robot's keyframes: sent it the %zu shared so far (%.1f s)",
        subscriber.getSubscriberName().c_str(), sent, (ros::WallTime::now() - start).toSec());
  }
}

bool FleetLink::onEvidence(FleetEvidence::Request& request, FleetEvidence::Response& response) {
  hooks_.with_detector([&](LoopDetector& detector) {
    if (request.map_id != detector.map().mapId()) {
      response.problem = "map " + std::to_string(request.map_id) + " is not this detector's (" +
                         std::to_string(detector.map().mapId()) + ")";
      return;
    }
    const std::optional<KeyframeEvidence> evidence =
        evidenceOf(detector, request.id, hooks_.intrinsics());
    if (!evidence) {
      response.problem = "keyframe " + std::to_string(request.id) + " cannot be read";
      return;
    }
    toEvidenceResponse(*evidence, &response);
  });
  ++evidence_answered_;
  return true;  // `found` says whether it was.
}

void FleetLink::onAnnounced(LoopDetector& detector, uint64_t id,
                            const std::string& odometry_frame) {
  if (!options_.share && options_.peerList().empty()) return;
  own_map_id_ = detector.map().mapId();
  const std::optional<SharedKeyframe> own = sharedKeyframeOf(detector, id, robot_, odometry_frame);
  if (!own) return;  // Not in search (past the memory budget): nothing to share or search.
  if (options_.share) {
    {
      std::lock_guard<std::mutex> lock(odometry_frame_mutex_);
      last_odometry_frame_ = odometry_frame;
    }
    row_publisher_.publish(toFleetKeyframeMsg(*own));
    ++rows_shared_;
  }
  if (options_.peerList().empty()) return;
  std::optional<Fetch> fetch;
  {
    std::lock_guard<std::mutex> lock(matcher_mutex_);
    if (std::optional<FleetCandidate> candidate = matcher_->query(*own)) {
      fetch = Fetch{*candidate, candidate->peer, odometry_frame};
    }
  }
  if (!fetch) return;
  fetch->candidate.query_map_id = detector.map().mapId();
  std::lock_guard<std::mutex> lock(fetch_mutex_);
  if (fetches_.size() >= kMaxWaitingFetches) {
    fetches_.pop_front();  // The newest candidates are the likeliest still to be worth it.
    ++candidates_dropped_;
  }
  fetches_.push_back(std::move(*fetch));
  fetch_ready_.notify_one();
}

void FleetLink::fetchLoop() {
  for (;;) {
    Fetch fetch;
    {
      std::unique_lock<std::mutex> lock(fetch_mutex_);
      fetch_ready_.wait(lock, [&] { return stopping_ || !fetches_.empty(); });
      if (stopping_) return;
      fetch = std::move(fetches_.front());
      fetches_.pop_front();
    }
    try {
      fetchAndCheck(fetch);
    } catch (const std::exception& error) {
      ++fetches_failed_;
      ROS_ERROR_THROTTLE(kWarningPeriod, "fleet: checking a candidate of robot %s threw (%s)",
                         fetch.peer.c_str(), error.what());
    }
  }
}

void FleetLink::fetchAndCheck(const Fetch& fetch) {
  const FleetCandidate& candidate = fetch.candidate;
  FleetEvidence::Request request;
  request.map_id = candidate.match.map_id;
  request.id = candidate.match.id;
  std::string problem;
  const std::string service = ros::names::resolve(fetch.peer + "/keyframe_evidence");
  const std::optional<FleetEvidence> answer =
      callWithTimeout(service, request, options_.fetch_timeout_s, &problem);
  ++fetches_made_;
  if (answer && !answer->response.found) {
    // Its words, cut to a log line's length.
    problem = answer->response.problem.substr(0, 200);
  }
  if (!answer || !answer->response.found) {
    ++fetches_failed_;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "fleet: the evidence of keyframe %lu of robot %s could not be fetched from "
                      "%s: %s",
                      static_cast<unsigned long>(candidate.match.id), candidate.match.robot.c_str(),
                      service.c_str(), problem.c_str());
    return;
  }
  std::shared_ptr<const KeyframeRecord> query;
  std::optional<LoopDetectorOptions> settings;
  hooks_.with_detector([&](LoopDetector& detector) {
    if (detector.map().mapId() != candidate.query_map_id) return;  // A load or reset meanwhile.
    query = detector.database().findRecord(candidate.query_id);
    settings = detector.options();
  });
  if (!query || !settings) return;
  // The peer's answer is untrusted: its sizes are bounded before it is converted, and it is
  // validated whole, then matched, with the detector free; only the network's pass over the two
  // thumbnails (the appearance check) takes it.
  const size_t max_keypoints =
      static_cast<size_t>(std::max(settings->verification.max_features, 0));
  std::string refused = evidenceResponseProblem(answer->response, max_keypoints);
  std::optional<KeyframeEvidence> evidence;
  if (refused.empty()) {
    evidence = evidenceFromResponse(request, answer->response);
    evidence_bytes_ += evidence->wireBytes();
    refused = evidence->problem(max_keypoints);
  }
  if (!refused.empty()) {
    ++fetches_failed_;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "fleet: the evidence of keyframe %lu of robot %s from %s was refused: %s",
                      static_cast<unsigned long>(candidate.match.id), candidate.match.robot.c_str(),
                      service.c_str(), refused.c_str());
    return;
  }
  const auto cells_of = [this](const std::vector<uint8_t>& thumbnail) -> CellsOfKeyframe {
    return [this, &thumbnail] {
      CellFeatures cells;
      hooks_.with_detector(
          [&](LoopDetector& detector) { cells = thumbnailCellsOf(detector, thumbnail)(); });
      return cells;
    };
  };
  const GeometricVerifier verifier(settings->verification);
  PlaceCheck check = checkFleetCandidate(
      verifier, {settings->verification, settings->appearance, settings->metric_pose},
      query->local_features, hooks_.intrinsics(), *evidence, cells_of(query->thumbnail),
      cells_of(evidence->thumbnail), options_.appearance_confirms, candidate.false_alarms);
  std::optional<LoopClosure> message;
  if (!check.accepted) refused = check.detail;
  hooks_.with_detector([&](LoopDetector& detector) {
    if (!check.accepted || detector.map().mapId() != candidate.query_map_id) return;
    AcceptedLoop loop;
    loop.map_id = detector.map().mapId();
    loop.query_id = query->id;
    loop.query_session = query->session;
    loop.query_stamp = query->stamp;
    loop.query_pose = query->pose;
    loop.match_id = candidate.match.id;
    loop.match_session = candidate.match.session;
    loop.match_stamp = candidate.match.stamp_ns * 1e-9;
    loop.match_pose = candidate.match.pose;
    loop.global_score = loop.rerank_score = loop.score = candidate.score;
    loop.consistent_keyframes = candidate.consistent_keyframes;
    loop.verification = std::move(check.verification);
    loop.appearance = check.appearance;
    loop.metric_pose = std::move(check.metric_pose);
    loop.relative_pose = check.relative_pose;
    const std::string pose_frame = hooks_.express_relative_pose(&loop);
    ros::Time query_stamp, match_stamp;
    query_stamp.fromNSec(static_cast<uint64_t>(detector.map().keyframeStampNs(query->id).value_or(
        static_cast<int64_t>(query->stamp * 1e9))));
    match_stamp.fromNSec(static_cast<uint64_t>(std::max<int64_t>(candidate.match.stamp_ns, 0)));
    message = toLoopMsg(loop, query_stamp, match_stamp, fetch.odometry_frame, pose_frame);
    message->match_map_id = candidate.match.map_id;
  });
  if (!message) {
    ++loops_refused_;
    ROS_INFO_THROTTLE(kWarningPeriod,
                      "fleet: keyframe %lu and keyframe %lu of robot %s refused: %s",
                      static_cast<unsigned long>(candidate.query_id),
                      static_cast<unsigned long>(candidate.match.id), candidate.match.robot.c_str(),
                      refused.empty() ? "the keyframe left this detector's map" : refused.c_str());
    return;
  }
  hooks_.publish_loop(*message);
  ++loops_published_;
  ROS_INFO(
      "Loop between robots: keyframe %lu matches keyframe %lu of robot %s (map %lu, score "
      "%.3f, %d consistent keyframes, %u inliers%s)",
      static_cast<unsigned long>(candidate.query_id),
      static_cast<unsigned long>(candidate.match.id), candidate.match.robot.c_str(),
      static_cast<unsigned long>(candidate.match.map_id), candidate.score,
      candidate.consistent_keyframes, message->inliers,
      message->has_relative_pose ? ", with a relative pose" : "");
}

void FleetLink::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  status.add("fleet rows shared", rows_shared_.load());
  status.add("fleet rows sent to late peers", backlog_rows_sent_.load());
  size_t rows = 0, bytes = 0, refused = 0;
  std::string robots;
  {
    std::lock_guard<std::mutex> lock(matcher_mutex_);
    {
      rows = matcher_->rows();
      bytes = matcher_->bytes();
      for (const FleetRobot& robot : matcher_->robots()) {
        refused += robot.rows_refused;
        robots += (robots.empty() ? "" : ", ") + robot.peer + " (" +
                  (robot.robot.empty() ? "" : robot.robot + ", ") + std::to_string(robot.rows) +
                  (robot.silent ? ", silent)" : ")");
      }
    }
  }
  status.add("fleet robots heard", robots.empty() ? "none" : robots);
  status.add("fleet rows kept", rows);
  status.add("fleet rows bytes", bytes);
  status.add("fleet rows refused", refused);
  status.add("fleet evidence fetched", fetches_made_.load());
  status.add("fleet evidence fetch failures", fetches_failed_.load());
  status.add("fleet evidence bytes fetched", evidence_bytes_.load());
  status.add("fleet candidates dropped", candidates_dropped_.load());
  status.add("fleet loops refused", loops_refused_.load());
  status.add("fleet loops published", loops_published_.load());
  status.add("fleet evidence answered", evidence_answered_.load());
}

}  // namespace landmark_loop_closure
