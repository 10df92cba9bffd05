// A hostile peer on the detector's ROS master (issue 81). The peer's rows copy the detector's first
// lap under another map_id, so that the detector's keyframes keep finding candidates in it and
// fetching their evidence; then, one corridor lap each, the peer floods its topic with rows that
// must be refused (a new robot name in every row, ids of 2^40 and more, NaN poses, the
// detector's own map_id), answers evidence requests with 10^6 keypoints (52 MB), with a
// 1 MB PNG that would decode to 1 GB, and never answers at all. Through every attack the detector
// stores its keyframes as in the quiet lap before, its memory and thread count stay put, and it
// says what it refuses in a few throttled lines.
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <string>
#include <vector>

#include <ros/callback_queue.h>
#include <ros/network.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include "landmark_loop_closure/FleetEvidence.h"
#include "landmark_loop_closure/FleetKeyframe.h"
#include "node_harness.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::sim;

namespace {

/// The process id of ROS node `name`, asked of the node itself (several tests may run a node of
/// that name on one machine, each under its own master); -1 when it cannot be had.
int pidOfNode(const std::string& name) {
  XmlRpc::XmlRpcValue args, result, uri;
  args[0] = ros::this_node::getName();
  args[1] = name;
  if (!ros::master::execute("lookupNode", args, result, uri, false)) return -1;
  std::string host;
  uint32_t port = 0;
  if (!ros::network::splitURI(static_cast<std::string>(uri), host, port)) return -1;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue request, response;
  request[0] = ros::this_node::getName();
  if (!client.execute("getPid", request, response) || response.size() < 3) return -1;
  return static_cast<int>(response[2]);
}

struct ProcessSample {
  size_t threads = 0;
  double rss_mb = 0.0;
};

ProcessSample sampleOf(int pid) {
  ProcessSample sample;
  const std::string dir = "/proc/" + std::to_string(pid);
  for (const auto& entry : std::filesystem::directory_iterator(dir + "/task")) {
    (void)entry;
    ++sample.threads;
  }
  std::ifstream status(dir + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) sample.rss_mb = std::stod(line.substr(6)) / 1024.0;
  }
  return sample;
}

enum class Answer { kProxy, kHuge, kPng, kNever };
const char* const kPhaseNames[] = {"quiet", "rows", "10^6 keypoints", "1 MB PNG", "no answer"};

/// The hostile peer's evidence service, on threads of its own.
class RogueEvidence {
 public:
  RogueEvidence() {
    ros::NodeHandle node;
    ros::AdvertiseServiceOptions options;
    options.init<FleetEvidence::Request, FleetEvidence::Response>(
        "/rogue/loop_closure/keyframe_evidence",
        [this](FleetEvidence::Request& request, FleetEvidence::Response& response) {
          return answer(request, response);
        });
    options.callback_queue = &queue_;
    server_ = node.advertiseService(options);
    spinner_ = std::make_unique<ros::AsyncSpinner>(2, &queue_);
    spinner_->start();
  }
  ~RogueEvidence() {
    set(Answer::kProxy);
    spinner_->stop();
  }
  void set(Answer answer) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      answer_ = answer;
    }
    changed_.notify_all();
  }
  int requests() const { return requests_.load(); }
  void setProxiedMap(uint64_t map_id) { proxied_map_ = map_id; }

 private:
  bool answer(FleetEvidence::Request& request, FleetEvidence::Response& response) {
    ++requests_;
    std::unique_lock<std::mutex> lock(mutex_);
    const Answer answer = answer_;
    if (answer == Answer::kNever) {
      changed_.wait(lock, [&] { return answer_ != Answer::kNever; });
      response.problem = "released";
      return true;
    }
    lock.unlock();
    response.image_width = 320;
    response.image_height = 240;
    response.intrinsics = {200.0, 200.0, 160.0, 120.0};
    if (answer == Answer::kProxy) {
      // A peer that behaves: the evidence is the detector's own, for the copy of its row.
      FleetEvidence proxied;
      proxied.request.map_id = proxied_map_.load();
      proxied.request.id = request.id;
      if (ros::service::call("/loop_closure/keyframe_evidence", proxied)) {
        response = proxied.response;
      } else {
        response.found = false;
        response.problem = "not here";
      }
    } else if (answer == Answer::kHuge) {
      constexpr size_t kKeypoints = 1000000;
      response.found = true;
      response.keypoints.assign(2 * kKeypoints, 10.0f);
      response.descriptors.assign(32 * kKeypoints, 0x5a);
      response.points3d.assign(3 * kKeypoints, std::numeric_limits<float>::quiet_NaN());
    } else {
      // A PNG's signature and a header of 32000x32000 pixels, grey, then 1 MB of a zlib stream's
      // worth of bytes: what a decoder would allocate about 1 GB for.
      response.found = true;
      response.keypoints.assign(2 * 20, 10.0f);
      response.descriptors.assign(32 * 20, 0x5a);
      response.points3d.assign(3 * 20, std::numeric_limits<float>::quiet_NaN());
      const uint8_t header[] = {0x89, 'P',  'N', 'G', '\r', '\n', 0x1a, '\n', 0,    0, 0,
                                13,   'I',  'H', 'D', 'R',  0,    0,    0x7d, 0x00, 0, 0,
                                0x7d, 0x00, 8,   0,   0,    0,    0,    0,    0,    0, 0};
      response.thumbnail.assign(header, header + sizeof(header));
      response.thumbnail.resize(1 << 20, 0);
    }
    return true;
  }

  ros::CallbackQueue queue_;
  ros::ServiceServer server_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  std::mutex mutex_;
  std::condition_variable changed_;
  Answer answer_ = Answer::kProxy;
  std::atomic<int> requests_{0};
  std::atomic<uint64_t> proxied_map_{0};
};

/// What the detector logged at WARN or above about the fleet, with wall times.
struct FleetLines {
  FleetLines() {
    ros::NodeHandle node;
    subscriber = node.subscribe<rosgraph_msgs::Log>(
        "/rosout", 1000, [this](const rosgraph_msgs::Log::ConstPtr& line) {
          if (line->name == "/loop_closure" && line->level >= rosgraph_msgs::Log::WARN &&
              line->msg.find("fleet") != std::string::npos) {
            times.push_back(ros::WallTime::now().toSec());
            texts.push_back(line->msg);
          }
        });
  }
  size_t between(double from, double to) const {
    size_t count = 0;
    for (const double time : times) count += time >= from && time < to ? 1 : 0;
    return count;
  }
  ros::Subscriber subscriber;
  std::vector<double> times;
  std::vector<std::string> texts;
};

uint64_t diagnosticCount(const test_support::NodeHarness& harness, const std::string& key) {
  const std::string value = harness.diagnostic(key);
  return value.empty() ? 0 : std::stoull(value);
}

}  // namespace

TEST(LoopClosureNode, AHostilePeerNeitherStallsTheDetectorNorGrowsIt) {
  int laps_per_phase = 1;
  double rate_hz = 30.0;
  ros::param::get("~laps_per_phase", laps_per_phase);
  ros::param::get("~rate_hz", rate_hz);
  test_support::NodeHarness harness;
  ASSERT_TRUE(harness.waitForNode()) << "the node did not subscribe";
  const int pid = pidOfNode("/loop_closure");
  ASSERT_GT(pid, 0) << "the node's process id";

  ros::NodeHandle node;
  ros::Publisher rogue_rows =
      node.advertise<FleetKeyframe>("/rogue/loop_closure/shared_keyframes", 1000);
  RogueEvidence evidence;
  bool relaying = true;
  std::vector<FleetKeyframe> own_rows;  // The detector's rows, as it shared them.
  uint64_t own_map_id = 0;
  ros::Subscriber relay = node.subscribe<FleetKeyframe>("/loop_closure/shared_keyframes", 1000,
                                                        [&](const FleetKeyframe::ConstPtr& row) {
                                                          own_map_id = row->map_id;
                                                          evidence.setProxiedMap(row->map_id);
                                                          own_rows.push_back(*row);
                                                          // The peer mapped the first lap only, as
                                                          // another robot would have: its map has
                                                          // each place once, however far this
                                                          // robot's odometry drifts in later laps.
                                                          if (!relaying) return;
                                                          FleetKeyframe copy = *row;
                                                          copy.robot = "rogue";
                                                          copy.map_id = row->map_id ^ 0x5a5a5a5aULL;
                                                          rogue_rows.publish(copy);
                                                        });
  FleetLines lines;
  const ros::WallTime subscribed_by = ros::WallTime::now() + ros::WallDuration(10.0);
  while (ros::ok() && (rogue_rows.getNumSubscribers() == 0 || relay.getNumPublishers() == 0) &&
         ros::WallTime::now() < subscribed_by) {
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
  }
  ASSERT_GT(rogue_rows.getNumSubscribers(), 0u) << "the detector did not subscribe to its peer";

  const CorridorWorld world;
  SequenceOptions options;
  constexpr int kPhases = 5;
  options.laps = static_cast<double>(kPhases * laps_per_phase);
  options.start_stamp = 1700000000.0;
  SequenceGenerator sequence(world, CameraModel{}, options);
  ros::WallRate rate(rate_hz);

  struct Phase {
    size_t keyframes = 0;
    ProcessSample start, end;
    size_t max_threads = 0, min_threads = std::numeric_limits<size_t>::max();
    double from_s = 0.0, to_s = 0.0;
    int requests = 0;
    uint64_t timeouts = 0, fetch_failures = 0, rows_refused = 0;
    size_t loops_into_peer = 0;  ///< Loops published into the peer's map (its copy of ours).
  };
  std::vector<Phase> phases(kPhases);
  int phase = -1;
  constexpr double kAttacksPerS = 50.0;
  double attacks_due = 0.0;
  size_t spam = 0, flood_answered = 0, flood_refused = 0;
  SequenceFrame frame;
  const auto loopsIntoPeer = [&] {
    return static_cast<size_t>(
        std::count_if(harness.loops().begin(), harness.loops().end(), [&](const LoopClosure& loop) {
          return loop.match_map_id != 0 && loop.match_map_id != own_map_id;
        }));
  };
  const auto close_phase = [&] {
    if (phase < 0) return;
    std::printf(
        "after %s: skipped (one out) %s, backing off %s, searches dropped %s, search ms "
        "%s, fetched %s\n",
        kPhaseNames[phase], harness.diagnostic("fleet fetches skipped (one out)").c_str(),
        harness.diagnostic("fleet fetches skipped (backing off a peer)").c_str(),
        harness.diagnostic("fleet searches dropped (the link behind)").c_str(),
        harness.diagnostic("fleet search ms (last, max)").c_str(),
        harness.diagnostic("fleet evidence fetched").c_str());
    Phase& done = phases[static_cast<size_t>(phase)];
    done.end = sampleOf(pid);
    done.to_s = ros::WallTime::now().toSec();
    done.requests = evidence.requests() - done.requests;
    done.timeouts = diagnosticCount(harness, "fleet fetches timed out") - done.timeouts;
    done.fetch_failures =
        diagnosticCount(harness, "fleet evidence fetch failures") - done.fetch_failures;
    done.rows_refused = diagnosticCount(harness, "fleet rows refused") - done.rows_refused;
    done.loops_into_peer = loopsIntoPeer() - done.loops_into_peer;
  };
  while (ros::ok() && sequence.next(&frame)) {
    const int lap_phase = frame.lap / laps_per_phase;
    if (lap_phase != phase) {
      close_phase();
      phase = lap_phase;
      Phase& next = phases[static_cast<size_t>(phase)];
      next.start = sampleOf(pid);
      next.from_s = ros::WallTime::now().toSec();
      next.requests = evidence.requests();
      next.timeouts = diagnosticCount(harness, "fleet fetches timed out");
      next.fetch_failures = diagnosticCount(harness, "fleet evidence fetch failures");
      next.rows_refused = diagnosticCount(harness, "fleet rows refused");
      next.loops_into_peer = loopsIntoPeer();
      const Answer answers[] = {Answer::kProxy, Answer::kProxy, Answer::kHuge, Answer::kPng,
                                Answer::kNever};
      evidence.set(answers[phase]);
    }
    relaying = frame.lap == 0;
    const size_t before = harness.publishedKeyframes().size();
    harness.publish(frame.stamp, frame.odom, frame.image);
    // The attacks run at 50 a second, whatever the camera's rate.
    attacks_due += kAttacksPerS / rate_hz;
    for (; phase == 1 && !own_rows.empty() && attacks_due >= 1.0; attacks_due -= 1.0) {
      // Rows each refused for its own reason.
      FleetKeyframe row = own_rows[spam % own_rows.size()];
      row.robot = "rogue";
      row.map_id = own_map_id ^ 0x5a5a5a5aULL;
      switch (spam % 4) {
        case 0:
          row.robot = "invented_" + std::to_string(spam);
          break;
        case 1:
          row.id = (uint64_t{1} << 40) + spam;
          break;
        case 2:
          row.pose.position.x = std::numeric_limits<double>::quiet_NaN();
          break;
        default:
          row.map_id = own_map_id;
          break;
      }
      rogue_rows.publish(row);
      ++spam;
    }
    for (; phase == 4 && attacks_due >= 1.0; attacks_due -= 1.0) {
      // A caller asking the detector for its evidence far faster than a peer would.
      FleetEvidence flood;
      flood.request.map_id = own_map_id;
      flood.request.id = own_rows.empty() ? 0 : own_rows.back().id;
      if (ros::service::call("/loop_closure/keyframe_evidence", flood)) {
        ++(flood.response.found ? flood_answered : flood_refused);
      }
    }
    if (phase != 1 && phase != 4) attacks_due = 0.0;
    rate.sleep();
    ros::spinOnce();
    Phase& now = phases[static_cast<size_t>(phase)];
    now.keyframes += harness.publishedKeyframes().size() - before;
    if (frame.index % 30 == 0) {
      const size_t threads = sampleOf(pid).threads;
      now.max_threads = std::max(now.max_threads, threads);
      now.min_threads = std::min(now.min_threads, threads);
    }
  }
  harness.waitUntilQuiet();
  close_phase();

  const Phase& quiet = phases[0];
  ASSERT_GT(quiet.keyframes, 50u);
  for (int i = 0; i < kPhases; ++i) {
    const Phase& measured = phases[static_cast<size_t>(i)];
    const double seconds = measured.to_s - measured.from_s;
    std::printf(
        "%-15s %5.1f s: %zu keyframes (%.3f of the quiet lap's), threads %zu-%zu (quiet %zu-%zu), "
        "RSS %.1f -> %.1f MB, %zu fleet warnings, %d evidence requests, %lu timed out, %lu "
        "fetches refused or failed, %lu rows refused, %zu loops into the peer's map\n",
        kPhaseNames[i], seconds, measured.keyframes,
        static_cast<double>(measured.keyframes) / static_cast<double>(quiet.keyframes),
        measured.min_threads, measured.max_threads, quiet.min_threads, quiet.max_threads,
        measured.start.rss_mb, measured.end.rss_mb, lines.between(measured.from_s, measured.to_s),
        measured.requests, static_cast<unsigned long>(measured.timeouts),
        static_cast<unsigned long>(measured.fetch_failures),
        static_cast<unsigned long>(measured.rows_refused), measured.loops_into_peer);
    if (i == 0) continue;
    SCOPED_TRACE(kPhaseNames[i]);
    EXPECT_GE(static_cast<double>(measured.keyframes), 0.95 * static_cast<double>(quiet.keyframes));
    EXPECT_LE(measured.max_threads, quiet.max_threads + 2);
    EXPECT_GE(measured.min_threads + 2, quiet.min_threads);
    EXPECT_LE(measured.end.rss_mb - measured.start.rss_mb, 50.0);
    // At most one line per reason and 10 s: rows refused for four reasons, evidence refused or not
    // fetched, loops refused.
    const size_t allowed = 6 * (static_cast<size_t>(seconds / 10.0) + 1);
    EXPECT_LE(lines.between(measured.from_s, measured.to_s), allowed);
  }
  EXPECT_GT(phases[1].rows_refused, spam * 9 / 10) << "the flood's rows are refused";
  EXPECT_LT(harness.diagnostic("fleet robots heard").size(), 200u)
      << harness.diagnostic("fleet robots heard");
  for (int i = 2; i < kPhases; ++i) {
    SCOPED_TRACE(kPhaseNames[i]);
    EXPECT_GT(phases[static_cast<size_t>(i)].requests, 0) << "the detector asked the peer";
    EXPECT_GT(phases[static_cast<size_t>(i)].fetch_failures, 0u) << "and refused its answers";
  }
  EXPECT_GT(phases[4].timeouts, 0u) << "requests never answered are ended";
  // The detector answers a caller at most advanced/fleet/evidence_requests_per_s (10) a second.
  const double flood_s = phases[4].to_s - phases[4].from_s;
  std::printf(
      "evidence requests of one caller at %.0f a second for %.1f s: %zu answered, %zu "
      "refused\n",
      kAttacksPerS, flood_s, flood_answered, flood_refused);
  EXPECT_LE(static_cast<double>(flood_answered), 10.0 * flood_s + 10.0);
  EXPECT_GT(flood_refused, flood_answered);
  EXPECT_EQ(harness.diagnostic("keyframes dropped (worker busy)"), "0");
  // The peer's proper answers (its copy of this detector's evidence) make loops; its attacks none
  // (but the one fetch that may have been out with a proper answer as an attack began).
  EXPECT_GT(quiet.loops_into_peer, 0u) << "evidence fetched and checked";
  for (int i = 2; i < kPhases; ++i) EXPECT_LE(phases[static_cast<size_t>(i)].loops_into_peer, 1u);
  for (const std::string& text : lines.texts) std::printf("  %s\n", text.c_str());
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_rogue_peer");
  ros::NodeHandle node;
  return RUN_ALL_TESTS();
}
