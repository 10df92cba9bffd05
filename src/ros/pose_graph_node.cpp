// The pose_graph nodelet: keyframes and loops from the detector into the ROS-free PoseGraph, which
// its own thread optimises whenever loops arrive; publishes the corrected keyframe path, the raw
// odometry path, map -> odom on tf and a marker of the loops it refused.
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>
#include <variant>

#include <nav_msgs/Path.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/Marker.h>
#include <pluginlib/class_list_macros.hpp>

#include "landmark_loop_closure/PoseGraphLoop.h"
#include "landmark_loop_closure/backend/pose_graph.h"
#include "messages/ros_conversions.h"
#include "ros_parameter_source.h"

namespace landmark_loop_closure {
namespace {

PoseGraphNodeOptions loadPoseGraphOptions(const ros::NodeHandle& private_node) {
  const RosParameterSource source(private_node);
  OptionReader reader(source);
  PoseGraphNodeOptions options;
  PoseGraphNodeOptions::parameters().read(&reader, &options);
  warnUnknownParameters(source, reader, private_node, "config/pose_graph.yaml");
  const std::string problems = reader.errors() + options.validate();
  if (!problems.empty()) throw std::invalid_argument(problems);
  return options;
}

geometry_msgs::PoseStamped stampedPose(const Pose& pose, const std::string& frame,
                                       const ros::Time& stamp) {
  geometry_msgs::PoseStamped stamped;
  stamped.header.frame_id = frame;
  stamped.header.stamp = stamp;
  stamped.pose = toRos(pose);
  return stamped;
}

}  // namespace

class PoseGraphNode {
 public:
  PoseGraphNode(ros::NodeHandle node, ros::NodeHandle private_node, PoseGraphNodeOptions options)
      : options_(std::move(options)), graph_(std::make_unique<PoseGraph>(options_.graph)) {
    if (options_.camera_mount_from_tf) {
      tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
      tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_);
    }
    corrected_publisher_ = private_node.advertise<nav_msgs::Path>("corrected_path", 1, true);
    odometry_publisher_ = private_node.advertise<nav_msgs::Path>("odometry_path", 1, true);
    verdict_publisher_ = private_node.advertise<PoseGraphLoop>("loop_verdicts", 100);
    rejected_publisher_ =
        private_node.advertise<visualization_msgs::Marker>("rejected_loops", 1, true);
    keyframe_subscriber_ = node.subscribe("keyframes", 1000, &PoseGraphNode::onKeyframe, this);
    loop_subscriber_ = node.subscribe("loop_closures", 100, &PoseGraphNode::onLoop, this);
    worker_ = std::thread([this] { work(); });
    if (options_.publish_tf && options_.tf_rate_hz > 0.0) {
      tf_timer_ = node.createTimer(ros::Duration(1.0 / options_.tf_rate_hz),
                                   [this](const ros::TimerEvent&) { sendCorrection(); });
    }
  }

  ~PoseGraphNode() {
    tf_timer_.stop();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    if (worker_.joinable()) worker_.join();
    summarise();
  }

 private:
  using Input = std::variant<Keyframe, LoopClosure>;

  void onKeyframe(const Keyframe& keyframe) { push(keyframe); }
  void onLoop(const LoopClosure& loop) { push(loop); }
  void push(Input input) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      inputs_.push_back(std::move(input));
    }
    wake_.notify_one();
  }

  void work() {
    for (;;) {
      std::deque<Input> batch;
      bool woken = false;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        woken =
            wake_.wait_for(lock, kPathCatchUp, [this] { return stopping_ || !inputs_.empty(); });
        if (stopping_) return;
        batch.swap(inputs_);
      }
      if (!woken) {
        // Quiet for a while (the robot stopped, the bag ended): the paths show every keyframe.
        if (graph_->keyframes() != keyframes_in_paths_) publishPaths(pathStamp());
        continue;
      }
      // Everything that came meanwhile enters first; one optimisation then serves every loop.
      bool new_loops = false;
      bool new_keyframes = false;
      for (const Input& input : batch) {
        if (const auto* keyframe = std::get_if<Keyframe>(&input)) {
          new_keyframes |= addKeyframe(*keyframe);
        } else {
          waiting_loops_.push_back(std::get<LoopClosure>(input));
        }
      }
      // A loop is published before its query keyframe: it waits for it (a few keyframes at most).
      std::vector<LoopClosure> still_waiting;
      for (const LoopClosure& loop : waiting_loops_) {
        if (graph_->hasKeyframe(loop.query_id) || graph_->keyframes() == 0 ||
            graph_->ids().back() > loop.query_id + kLoopWaitKeyframes) {
          new_loops |= addLoop(loop);
        } else {
          still_waiting.push_back(loop);
        }
      }
      // Loops waiting for keyframes that never come (ids from elsewhere) must not pile up.
      while (still_waiting.size() > kMaxWaitingLoops) {
        new_loops |= addLoop(still_waiting.front());
        still_waiting.erase(still_waiting.begin());
      }
      waiting_loops_.swap(still_waiting);
      if (new_loops) {
        const OptimisationReport report = graph_->optimise();
        if (report.ran) optimisation_ms_.push_back(report.milliseconds);
        for (const uint64_t index : report.switched_off) {
          const LoopVerdict& verdict = graph_->loopVerdicts()[index];
          ROS_WARN("Pose graph: loop %lu -> %lu switched off: %s",
                   static_cast<unsigned long>(graph_loops_[index].query_id),
                   static_cast<unsigned long>(graph_loops_[index].match_id),
                   verdict.detail.c_str());
          publishVerdict(graph_loops_[index], toString(verdict.decision), verdict.error_sd,
                         verdict.detail);
        }
      }
      if (new_loops || new_keyframes) publish(new_loops);
    }
  }

  bool addKeyframe(const Keyframe& keyframe) {
    if (map_id_ && *map_id_ != keyframe.map_id) startOver(keyframe);
    const std::string problem = graph_->addKeyframe(keyframe.id, fromRos(keyframe.pose));
    if (!problem.empty()) {
      ROS_WARN_THROTTLE(10.0, "Pose graph: keyframe dropped: %s", problem.c_str());
      return false;
    }
    map_id_ = keyframe.map_id;
    odometry_frame_ = keyframe.header.frame_id;
    stamps_.push_back(keyframe.header.stamp);
    return true;
  }

  /// The detector went on in another map (it was reset, loaded one, or restarted): a new graph
  /// for it. While time goes on the odometry frame is the same, so the new graph starts from the
  /// old one's correction (map -> odom does not jump); after time went back (a bag played again)
  /// the odometry starts afresh, and so does the correction.
  void startOver(const Keyframe& keyframe) {
    const bool time_went_back = !stamps_.empty() && keyframe.header.stamp < stamps_.back();
    const Eigen::Isometry3d correction =
        time_went_back ? Eigen::Isometry3d::Identity() : graph_->mapFromOdometry();
    char text[400];
    std::snprintf(
        text, sizeof(text),
        "Pose graph: keyframe %lu is of map %lu, not %lu (the detector was reset, loaded a map or "
        "restarted): a new graph starts with it, %s; the old graph's %zu keyframes and %zu loops "
        "are dropped",
        static_cast<unsigned long>(keyframe.id), static_cast<unsigned long>(keyframe.map_id),
        static_cast<unsigned long>(*map_id_),
        time_went_back ? "map -> odom from identity (time went back: a new timeline)"
                       : "map -> odom where the old graph left it",
        graph_->keyframes(), graph_->loopVerdicts().size());
    // Throttled when the old graph had a single keyframe: two detectors on one topic would start
    // a graph at every keyframe.
    if (graph_->keyframes() > 1) {
      ROS_WARN("%s", text);
    } else {
      ROS_WARN_THROTTLE(10.0, "%s", text);
    }
    for (const LoopVerdict& verdict : graph_->loopVerdicts()) {
      ++earlier_decisions_[toString(verdict.decision)];
    }
    ++graphs_dropped_;
    graph_ = std::make_unique<PoseGraph>(options_.graph, correction);
    map_id_.reset();
    stamps_.clear();
    graph_loops_.clear();
    paths_stale_ = true;
  }

  bool addLoop(const LoopClosure& loop) {
    const char* left_out = nullptr;
    if (!loop.has_relative_pose) {
      left_out = "no relative pose (verified by appearance, or the pose was ambiguous)";
    } else if (!loop.relative_pose_metric) {
      left_out = "scale-free relative pose (a metric graph takes metric loops only)";
    } else if (loop.query_session != loop.match_session) {
      left_out = "it joins another run's map, whose odometry frame is not this one";
    } else if (map_id_ && loop.map_id != *map_id_) {
      left_out = "another map than the keyframes'";
    }
    std::optional<Eigen::Isometry3d> mount;
    std::string mount_problem;
    if (!left_out && loop.relative_pose_frame != options_.base_frame) {
      mount = mountOf(loop.relative_pose_frame, &mount_problem);
      if (!mount) left_out = "its frame is not on tf (camera_mount/from_tf)";
    }
    if (left_out) {
      ++left_out_[left_out];
      publishVerdict(loop, "left_out", 0.0, mount_problem.empty() ? left_out : mount_problem);
      return false;
    }
    LoopConstraint constraint = loopConstraintFromMsg(loop);
    if (mount) constraint = loopInBaseFrame(constraint, *mount);
    graph_loops_.push_back(loop);
    const LoopVerdict verdict = graph_->addLoop(constraint);
    publishVerdict(loop, toString(verdict.decision), verdict.error_sd, verdict.detail);
    for (const size_t index : verdict.confirmed) {
      const LoopVerdict& confirmed = graph_->loopVerdicts()[index];
      publishVerdict(graph_loops_[index], toString(confirmed.decision), confirmed.error_sd,
                     confirmed.detail);
    }
    if (verdict.decision == LoopDecision::kAwaitingConfirmation) {
      ROS_DEBUG("Pose graph: loop %lu -> %lu %s", static_cast<unsigned long>(loop.query_id),
                static_cast<unsigned long>(loop.match_id), verdict.detail.c_str());
    } else if (verdict.decision == LoopDecision::kUnknownKeyframe ||
               verdict.decision == LoopDecision::kBadPose ||
               verdict.decision == LoopDecision::kBadCovariance) {
      ROS_WARN_THROTTLE(10.0, "Pose graph: loop %lu -> %lu dropped as bad input (%s): %s",
                        static_cast<unsigned long>(loop.query_id),
                        static_cast<unsigned long>(loop.match_id),
                        toString(verdict.decision).c_str(), verdict.detail.c_str());
    } else if (verdict.decision != LoopDecision::kAccepted) {
      ROS_WARN("Pose graph: loop %lu -> %lu refused (%s): %s",
               static_cast<unsigned long>(loop.query_id), static_cast<unsigned long>(loop.match_id),
               toString(verdict.decision).c_str(), verdict.detail.c_str());
    }
    return verdict.decision == LoopDecision::kAccepted || !verdict.confirmed.empty();
  }

  /// base_frame <- `frame`: camera_mount, or tf's (latest, kept: a mount does not move). Empty,
  /// with `problem` saying why, while tf does not know it.
  std::optional<Eigen::Isometry3d> mountOf(const std::string& frame, std::string* problem) {
    const auto known = mounts_.find(frame);
    if (known != mounts_.end()) return known->second;
    if (!options_.camera_mount_from_tf) {
      // Said once per frame: a detector's base frame under another name would be taken for the
      // camera's here.
      const CameraMount& mount = options_.camera_mount;
      ROS_INFO(
          "Pose graph: loops in '%s' are taken as the camera's and turned into %s with "
          "camera_mount (%.3f, %.3f, %.3f m; roll %.3f, pitch %.3f, yaw %.3f rad); "
          "camera_mount/from_tf looks each loop's frame up in tf instead",
          frame.c_str(), options_.base_frame.c_str(), mount.x, mount.y, mount.z, mount.roll,
          mount.pitch, mount.yaw);
      return mounts_[frame] = mount.toPose().toIsometry();
    }
    std::string error;
    if (frame.empty()) {
      error = "the loop names no relative_pose_frame";
    } else if (tf_buffer_->canTransform(options_.base_frame, frame, ros::Time(0), &error)) {
      const Eigen::Isometry3d mount = tf2::transformToEigen(
          tf_buffer_->lookupTransform(options_.base_frame, frame, ros::Time(0)));
      ROS_INFO(
          "Pose graph: loops in %s turned into %s through tf, the frame at (%.3f, %.3f, "
          "%.3f) m",
          frame.c_str(), options_.base_frame.c_str(), mount.translation().x(),
          mount.translation().y(), mount.translation().z());
      return mounts_[frame] = mount;
    }
    *problem =
        "no tf " + options_.base_frame + " -> '" + frame + "' (camera_mount/from_tf): " + error;
    ROS_WARN_THROTTLE(10.0, "Pose graph: loop left out: %s", problem->c_str());
    return std::nullopt;
  }

  void publishVerdict(const LoopClosure& loop, const std::string& decision, double error_sd,
                      const std::string& detail) {
    PoseGraphLoop verdict;
    verdict.header.stamp = loop.query_stamp;
    verdict.header.frame_id = options_.map_frame;
    verdict.map_id = loop.map_id;
    verdict.query_id = loop.query_id;
    verdict.match_id = loop.match_id;
    verdict.query_stamp = loop.query_stamp;
    verdict.match_stamp = loop.match_stamp;
    verdict.decision = decision;
    verdict.error_sd = error_sd;
    verdict.detail = detail;
    verdict_publisher_.publish(verdict);
  }

  /// map_frame -> odometry frame, as the last keyframe left it; stamped tf_future_s ahead of
  /// the clock unless a stamp is given.
  void sendCorrection(std::optional<ros::Time> stamp = std::nullopt) {
    std::optional<std::pair<Eigen::Isometry3d, std::string>> correction;
    {
      std::lock_guard<std::mutex> lock(correction_mutex_);
      correction = correction_;
    }
    if (!correction) return;
    geometry_msgs::TransformStamped transform = tf2::eigenToTransform(correction->first);
    transform.header.stamp =
        stamp ? *stamp : ros::Time::now() + ros::Duration(options_.tf_future_s);
    transform.header.frame_id = options_.map_frame;
    transform.child_frame_id = correction->second;
    broadcaster_.sendTransform(transform);
  }

  ros::Time pathStamp() const { return stamps_.empty() ? ros::Time::now() : stamps_.back(); }

  void publish(bool optimised) {
    const ros::Time stamp = pathStamp();
    if (options_.publish_tf && !odometry_frame_.empty()) {
      {
        std::lock_guard<std::mutex> lock(correction_mutex_);
        correction_ = {graph_->mapFromOdometry(), odometry_frame_};
      }
      // Without the timer, the correction first: a viewer looking the path up at its stamp
      // then finds it.
      if (options_.tf_rate_hz <= 0.0) sendCorrection(stamp);
    }
    // The whole corrected path after an optimisation, else every 10 keyframes (it grows), and
    // when no input has come for a while (above).
    if (optimised || paths_stale_ || graph_->keyframes() % 10 == 0) publishPaths(stamp);
  }

  void publishPaths(const ros::Time& stamp) {
    if (paths_stale_) clearRejected(stamp);
    paths_stale_ = false;
    keyframes_in_paths_ = graph_->keyframes();
    nav_msgs::Path corrected;
    nav_msgs::Path odometry;
    corrected.header.frame_id = options_.map_frame;
    odometry.header.frame_id = odometry_frame_;
    corrected.header.stamp = odometry.header.stamp = stamp;
    const std::vector<uint64_t>& ids = graph_->ids();
    for (size_t i = 0; i < ids.size(); ++i) {
      corrected.poses.push_back(
          stampedPose(*graph_->optimisedPose(ids[i]), options_.map_frame, stamps_[i]));
      odometry.poses.push_back(
          stampedPose(*graph_->odometryPose(ids[i]), odometry_frame_, stamps_[i]));
    }
    corrected_publisher_.publish(corrected);
    odometry_publisher_.publish(odometry);
    publishRejected(stamp);
  }

  visualization_msgs::Marker rejectedMarker(const ros::Time& stamp) const {
    visualization_msgs::Marker marker;
    marker.header.frame_id = options_.map_frame;
    marker.header.stamp = stamp;
    marker.ns = "rejected_loops";
    return marker;
  }

  /// A new graph has refused nothing yet: the old graph's refusals leave rviz.
  void clearRejected(const ros::Time& stamp) {
    visualization_msgs::Marker marker = rejectedMarker(stamp);
    marker.action = visualization_msgs::Marker::DELETEALL;
    rejected_publisher_.publish(marker);
  }

  void publishRejected(const ros::Time& stamp) {
    visualization_msgs::Marker marker = rejectedMarker(stamp);
    marker.type = visualization_msgs::Marker::LINE_LIST;
    marker.action = visualization_msgs::Marker::ADD;
    marker.pose.orientation.w = 1.0;
    marker.scale.x = 0.03;
    marker.color.r = 1.0;
    marker.color.a = 1.0;
    const std::vector<LoopVerdict>& verdicts = graph_->loopVerdicts();
    for (size_t k = 0; k < verdicts.size(); ++k) {
      // A loop still awaiting confirmation is not a refusal (yet).
      if (verdicts[k].decision == LoopDecision::kAccepted ||
          verdicts[k].decision == LoopDecision::kAwaitingConfirmation) {
        continue;
      }
      const std::optional<Pose> query = graph_->optimisedPose(graph_loops_[k].query_id);
      const std::optional<Pose> match = graph_->optimisedPose(graph_loops_[k].match_id);
      if (!query || !match) continue;
      for (const Pose* end : {&*query, &*match}) {
        geometry_msgs::Point point;
        point.x = end->position.x();
        point.y = end->position.y();
        point.z = end->position.z();
        marker.points.push_back(point);
      }
    }
    // Refusals only accumulate; rviz calls an empty line list an error, so none is sent.
    if (!marker.points.empty()) rejected_publisher_.publish(marker);
  }

  void summarise() const {
    std::map<std::string, size_t> decisions = earlier_decisions_;
    for (const LoopVerdict& verdict : graph_->loopVerdicts())
      ++decisions[toString(verdict.decision)];
    std::string text;
    for (const auto& [decision, count] : decisions) {
      text += " " + decision + " " + std::to_string(count);
    }
    for (const auto& [reason, count] : left_out_) {
      text += "; left out " + std::to_string(count) + ": " + reason;
    }
    std::vector<double> times = optimisation_ms_;
    std::sort(times.begin(), times.end());
    const double median = times.empty() ? 0.0 : times[times.size() / 2];
    // A rate of 0 from a graph told not to estimate one would read as a measurement.
    char drift[64] = "not estimated";
    if (options_.graph.heading_drift_prior_sd_per_m > 0.0) {
      std::snprintf(drift, sizeof(drift), "estimated %.4f rad/m", graph_->headingDriftPerMetre());
    }
    char earlier[80] = "";
    if (graphs_dropped_ > 0) {
      std::snprintf(earlier, sizeof(earlier), " (%zu earlier graph(s) of other maps dropped)",
                    graphs_dropped_);
    }
    char line[320];
    std::snprintf(line, sizeof(line),
                  "Pose graph: %zu keyframes%s; %zu optimisations, median %.1f ms; odometry "
                  "heading drift %s;",
                  graph_->keyframes(), earlier, times.size(), median, drift);
    // At SIGINT ROS has shut its console down before the nodelet is destroyed: say it directly.
    if (ros::ok()) {
      ROS_INFO("%s loops:%s", line, text.c_str());
    } else {
      std::fprintf(stderr, "%s loops:%s\n", line, text.c_str());
    }
  }

  static constexpr uint64_t kLoopWaitKeyframes = 10;
  static constexpr size_t kMaxWaitingLoops = 100;
  static constexpr std::chrono::seconds kPathCatchUp{1};

  PoseGraphNodeOptions options_;
  std::unique_ptr<PoseGraph> graph_;
  std::vector<LoopClosure> waiting_loops_;
  std::optional<uint64_t> map_id_;
  std::string odometry_frame_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;  ///< camera_mount/from_tf only.
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::map<std::string, Eigen::Isometry3d> mounts_;  ///< base_frame <- each loop frame seen.
  std::vector<ros::Time> stamps_;
  std::vector<LoopClosure> graph_loops_;  ///< As given to the graph, in its loop order.
  std::map<std::string, size_t> left_out_;
  std::map<std::string, size_t> earlier_decisions_;  ///< Of the graphs of earlier maps.
  size_t graphs_dropped_ = 0;
  bool paths_stale_ = false;       ///< A new graph: its paths replace the old one's at once.
  size_t keyframes_in_paths_ = 0;  ///< In the paths last published.
  std::vector<double> optimisation_ms_;

  ros::Publisher corrected_publisher_;
  ros::Publisher odometry_publisher_;
  ros::Publisher rejected_publisher_;
  ros::Publisher verdict_publisher_;
  ros::Subscriber keyframe_subscriber_;
  ros::Subscriber loop_subscriber_;
  tf2_ros::TransformBroadcaster broadcaster_;
  ros::Timer tf_timer_;
  std::mutex correction_mutex_;
  std::optional<std::pair<Eigen::Isometry3d, std::string>>
      correction_;  ///< And the odometry frame.

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<Input> inputs_;
  bool stopping_ = false;
  std::thread worker_;
};

class PoseGraphNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    PoseGraphNodeOptions options;
    try {
      options = loadPoseGraphOptions(getPrivateNodeHandle());
    } catch (const std::invalid_argument& problems) {
      NODELET_FATAL("Refusing to start, fix these parameters:\n%s", problems.what());
      throw;
    }
    node_ = std::make_unique<PoseGraphNode>(getNodeHandle(), getPrivateNodeHandle(), options);
  }

  std::unique_ptr<PoseGraphNode> node_;
};

}  // namespace landmark_loop_closure

PLUGINLIB_EXPORT_CLASS(landmark_loop_closure::PoseGraphNodelet, nodelet::Nodelet)
