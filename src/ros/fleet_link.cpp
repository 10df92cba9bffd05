#include "fleet_link.h"

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "messages/ros_conversions.h"

namespace landmark_loop_closure {

namespace {

constexpr size_t kMaxWaitingSearches = 8;  // Own rows waiting for the searcher.
constexpr double kWarningPeriod = 10.0;
constexpr double kSilenceCheckPeriod = 5.0;
// Each caller's evidence requests a second (bursts of as many); all callers together may make
// kEvidenceCallersAtOnce times that.
constexpr double kEvidenceCallersAtOnce = 4.0;

/// The largest evidence answer a receiver reads: max_features keypoints of 56 bytes (point,
/// descriptor, 3-D point, depth sd), a thumbnail of at most 64 KB, a problem line, two frame names
/// (256 bytes each) and the fields.
size_t maxEvidenceBytes(int max_features) {
  return static_cast<size_t>(std::max(max_features, 0)) * 56 + 64 * 1024 + 4096;
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
      own_map_id_(detector.map().mapId()),
      evidence_rate_(options.evidence_requests_per_s,
                     options.evidence_requests_per_s * kEvidenceCallersAtOnce) {
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
    service.initBySpecType<ros::ServiceEvent<FleetEvidence::Request, FleetEvidence::Response>>(
        "keyframe_evidence",
        [this](ros::ServiceEvent<FleetEvidence::Request, FleetEvidence::Response>& event) {
          return onEvidence(event);
        });
    service.callback_queue = &service_queue_;
    evidence_service_ = private_node_.advertiseService(service);
    service_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &service_queue_);
    service_spinner_->start();
  }
  const size_t max_answer_bytes = maxEvidenceBytes(detector.options().verification.max_features);
  for (const std::string& peer : options_.peerList()) {
    channels_[peer] =
        std::make_unique<EvidenceChannel>(ros::names::resolve(peer + "/keyframe_evidence"),
                                          options_.fetch_timeout_s, max_answer_bytes);
    const std::string topic = ros::names::resolve(peer + "/shared_keyframes");
    row_subscribers_.push_back(node_.subscribe<FleetKeyframe>(
        topic, 1000, [this, peer](const FleetKeyframe::ConstPtr& msg) { onRow(peer, msg); }));
    ROS_INFO("fleet: keeping and searching the keyframes robot %s shares on %s", peer.c_str(),
             topic.c_str());
  }
  if (!options_.peerList().empty()) {
    searcher_ = std::make_unique<FleetSearcher>(
        *matcher_, matcher_mutex_, kMaxWaitingSearches,
        [this](const FleetSearcher::Search& own, std::optional<FleetCandidate> candidate, double) {
          if (candidate) fetch(own, *candidate);
        },
        [](const FleetSearcher::Search& own, const std::string& what) {
          ROS_ERROR_THROTTLE(kWarningPeriod,
                             "fleet: searching keyframe %lu in other robots' maps threw (%s)",
                             static_cast<unsigned long>(own.row.id), what.c_str());
        });
    silence_timer_ = node_.createWallTimer(
        ros::WallDuration(kSilenceCheckPeriod), [this](const ros::WallTimerEvent&) {
          MutexLock lock(matcher_mutex_);
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
  if (searcher_) searcher_->stop();
  for (auto& [peer, channel] : channels_) channel->stop();
}

void FleetLink::onRow(const std::string& peer, const FleetKeyframe::ConstPtr& msg) {
  // Converted outside the lock; the matcher validates the row whole before it keeps anything.
  const SharedKeyframe row = sharedKeyframeFromMsg(*msg);
  RowVerdict verdict;
  {
    MutexLock lock(matcher_mutex_);
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
    MutexLock lock(odometry_frame_mutex_);
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
    counters_.backlog_rows_sent += rows.size();
    if (more) ros::WallDuration(chunk_period_s).sleep();
  }
  if (sent > 0) {
    ROS_INFO(
        "fleet: %s subscribed to this robot's keyframes: sent it the %zu shared so far (%.1f s)",
        subscriber.getSubscriberName().c_str(), sent, (ros::WallTime::now() - start).toSec());
  }
}

bool FleetLink::onEvidence(
    ros::ServiceEvent<FleetEvidence::Request, FleetEvidence::Response>& event) {
  const FleetEvidence::Request& request = event.getRequest();
  FleetEvidence::Response& response = event.getResponse();
  // Bounded before the detector is taken: a caller asking faster than a peer's fetches could
  // (one out at a time per peer) is answered with a refusal, and holds the detector no longer.
  const std::string caller = event.getCallerName().substr(0, 256);
  if (!evidence_rate_.allow(caller, ros::WallTime::now().toSec())) {
    ++counters_.evidence_refused;
    response.found = false;
    response.problem =
        "too many requests: at most advanced/fleet/evidence_requests_per_s a "
        "caller";
    // One key for every caller: names a caller invents add none.
    if (evidence_refusals_.allow("rate", ros::WallTime::now().toSec())) {
      ROS_WARN(
          "fleet: evidence requests of %s refused past advanced/fleet/evidence_requests_per_s "
          "(%.0f a second)",
          caller.substr(0, 64).c_str(), options_.evidence_requests_per_s);
    }
    return true;
  }
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
    KeyframeEvidence answer = *evidence;
    answer.base_frame = hooks_.base_frame;
    answer.camera_frame = hooks_.camera_frame();
    toEvidenceResponse(answer, &response);
  });
  ++counters_.evidence_answered;
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
      MutexLock lock(odometry_frame_mutex_);
      last_odometry_frame_ = odometry_frame;
    }
    row_publisher_.publish(toFleetKeyframeMsg(*own));
    ++counters_.rows_shared;
  }
  if (searcher_) searcher_->hand({*own, detector.map().mapId(), odometry_frame});
}

void FleetLink::fetch(const FleetSearcher::Search& own, const FleetCandidate& candidate) {
  const auto channel = channels_.find(candidate.peer);
  if (channel == channels_.end()) return;  // A map is owned by a peer named in fleet/peers.
  FleetEvidence::Request request;
  request.map_id = candidate.match.map_id;
  request.id = candidate.match.id;
  EvidenceChannel* const link = channel->second.get();
  const EvidenceChannel::Offer offer = link->offer(
      request,
      [this, link, candidate, frame = own.odometry_frame](const EvidenceChannel::Answer& answer) {
        bool usable = false;
        try {
          usable = checkFetched(candidate, frame, link->service(), answer);
        } catch (const std::exception& error) {
          ++counters_.fetches_failed;
          ROS_ERROR_THROTTLE(kWarningPeriod, "fleet: checking a candidate of robot %s threw (%s)",
                             candidate.peer.c_str(), error.what());
        }
        link->noteAnswer(usable);
      });
  // Not asked: the next keyframe may ask again.
  if (offer == EvidenceChannel::Offer::kBusy) ++counters_.fetches_skipped;
  if (offer == EvidenceChannel::Offer::kBackingOff) ++counters_.fetches_backed_off;
}

bool FleetLink::checkFetched(const FleetCandidate& candidate, const std::string& odometry_frame,
                             const std::string& service, const EvidenceChannel::Answer& answer) {
  ++counters_.fetches_made;
  std::string problem = answer.problem;
  if (answer.response && !answer.response->found) {
    // Its words, cut to a log line's length.
    problem = answer.response->problem.substr(0, 200);
  }
  if (!answer.response || !answer.response->found) {
    ++counters_.fetches_failed;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "fleet: the evidence of keyframe %lu of robot %s could not be fetched from "
                      "%s: %s",
                      static_cast<unsigned long>(candidate.match.id), candidate.peer.c_str(),
                      service.c_str(), problem.c_str());
    return false;
  }
  FleetEvidence::Request request;
  request.map_id = candidate.match.map_id;
  request.id = candidate.match.id;
  const FleetEvidence::Response& response = *answer.response;
  std::shared_ptr<const KeyframeRecord> query;
  std::optional<LoopDetectorOptions> settings;
  hooks_.with_detector([&](LoopDetector& detector) {
    if (detector.map().mapId() != candidate.query_map_id) return;  // A load or reset meanwhile.
    query = detector.database().findRecord(candidate.query_id);
    settings = detector.options();
  });
  if (!query || !settings) return true;  // The peer's answer is not to blame.
  // The peer's answer is untrusted: its sizes are bounded before it is converted, and it is
  // validated whole, then matched, with the detector free; only the network's pass over the two
  // thumbnails (the appearance check) takes it.
  const size_t max_keypoints =
      static_cast<size_t>(std::max(settings->verification.max_features, 0));
  std::string refused = evidenceResponseProblem(response, max_keypoints);
  std::optional<KeyframeEvidence> evidence;
  counters_.evidence_bytes += answer.bytes;
  if (refused.empty()) {
    evidence = evidenceFromResponse(request, response);
    refused = evidence->problem(max_keypoints);
  }
  if (!refused.empty()) {
    ++counters_.fetches_failed;
    ROS_WARN_THROTTLE(kWarningPeriod,
                      "fleet: the evidence of keyframe %lu of robot %s from %s was refused: %s",
                      static_cast<unsigned long>(candidate.match.id), candidate.match.robot.c_str(),
                      service.c_str(), refused.c_str());
    return false;
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
    loop.match_map_id = candidate.match.map_id;
    loop.match_odometry_frame = candidate.match.odometry_frame;
    loop.match_camera_mount = evidence->camera_mount;
    const std::string pose_frame = hooks_.express_relative_pose(&loop);
    ros::Time query_stamp, match_stamp;
    query_stamp.fromNSec(static_cast<uint64_t>(detector.map().keyframeStampNs(query->id).value_or(
        static_cast<int64_t>(query->stamp * 1e9))));
    match_stamp.fromNSec(static_cast<uint64_t>(std::max<int64_t>(candidate.match.stamp_ns, 0)));
    message = toLoopMsg(loop, query_stamp, match_stamp, odometry_frame, pose_frame);
  });
  if (!message) {
    ++counters_.loops_refused;
    ROS_INFO_THROTTLE(kWarningPeriod,
                      "fleet: keyframe %lu and keyframe %lu of robot %s refused: %s",
                      static_cast<unsigned long>(candidate.query_id),
                      static_cast<unsigned long>(candidate.match.id), candidate.match.robot.c_str(),
                      refused.empty() ? "the keyframe left this detector's map" : refused.c_str());
    return true;
  }
  hooks_.publish_loop(*message);
  ++counters_.loops_published;
  ROS_INFO(
      "Loop between robots: keyframe %lu matches keyframe %lu of robot %s (map %lu, score "
      "%.3f, %d consistent keyframes, %u inliers%s)",
      static_cast<unsigned long>(candidate.query_id),
      static_cast<unsigned long>(candidate.match.id), candidate.match.robot.c_str(),
      static_cast<unsigned long>(candidate.match.map_id), candidate.score,
      candidate.consistent_keyframes, message->inliers,
      message->has_relative_pose ? ", with a relative pose" : "");
  return true;
}

void FleetLink::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  status.add("fleet rows shared", counters_.rows_shared.load());
  status.add("fleet rows sent to late peers", counters_.backlog_rows_sent.load());
  size_t rows = 0, bytes = 0, refused = 0;
  std::string robots;
  {
    MutexLock lock(matcher_mutex_);
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
  status.add("fleet evidence fetched", counters_.fetches_made.load());
  status.add("fleet evidence fetch failures", counters_.fetches_failed.load());
  status.add("fleet evidence bytes fetched", counters_.evidence_bytes.load());
  status.add("fleet searches dropped (the link behind)", searcher_ ? searcher_->dropped() : 0);
  status.add("fleet fetches skipped (one out)", counters_.fetches_skipped.load());
  status.add("fleet fetches skipped (backing off a peer)", counters_.fetches_backed_off.load());
  uint64_t timeouts = 0;
  for (const auto& [peer, channel] : channels_) timeouts += channel->timeouts();
  status.add("fleet fetches timed out", timeouts);
  status.addf("fleet search ms (last, max)", "%.2f, %.2f",
              searcher_ ? searcher_->lastMilliseconds() : 0.0,
              searcher_ ? searcher_->maxMilliseconds() : 0.0);
  status.add("fleet loops refused", counters_.loops_refused.load());
  status.add("fleet loops published", counters_.loops_published.load());
  status.add("fleet evidence answered", counters_.evidence_answered.load());
  status.add("fleet evidence requests refused (rate)", counters_.evidence_refused.load());
}

}  // namespace landmark_loop_closure
