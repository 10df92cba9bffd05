// The pose_graph nodelet: keyframes and loops from the detector into the ROS-free
// PoseGraphRuntime, whose own thread optimises whenever loops arrive; publishes the corrected
// keyframe path, the raw odometry path, map -> odom on tf, each loop's verdict and a marker of
// the loops the graph refused.
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <utility>
#include <vector>

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
#include "landmark_loop_closure/backend/pose_graph_runtime.h"
#include "landmark_loop_closure/common/thread_annotations.h"
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

// The camera mount and base frame of the detector named by options->detector, from its
// parameters: the mount is set once, for both nodes. Says at start which values are used.
void takeDetectorsMount(const ros::NodeHandle& node, PoseGraphNodeOptions* options) {
  if (options->detector.empty()) return;
  const ros::NodeHandle detector(node, options->detector);
  // The graph lives beside the detector's map: saved with it, restored with it.
  std::string database_path;
  detector.param("database_path", database_path, std::string());
  if (!database_path.empty()) options->graph_file = database_path + "-pose_graph";
  if (!detector.hasParam("camera_mount")) {
    ROS_WARN(
        "Pose graph: the detector %s has no camera_mount parameters (another name? set "
        "detector); this node's own camera_mount values are used",
        detector.getNamespace().c_str());
    return;
  }
  CameraMount mount;
  bool from_tf = false;
  detector.param("camera_mount/x", mount.x, mount.x);
  detector.param("camera_mount/y", mount.y, mount.y);
  detector.param("camera_mount/z", mount.z, mount.z);
  detector.param("camera_mount/roll", mount.roll, mount.roll);
  detector.param("camera_mount/pitch", mount.pitch, mount.pitch);
  detector.param("camera_mount/yaw", mount.yaw, mount.yaw);
  // The detector's file has it under advanced/ (its name before that still read, as the
  // detector reads it).
  if (!detector.getParam("advanced/camera_mount/from_tf", from_tf)) {
    detector.param("camera_mount/from_tf", from_tf, false);
  }
  if (const std::string problem = mount.validate(); !problem.empty()) {
    ROS_ERROR(
        "Pose graph: the detector %s's camera_mount is not usable (%s); this node's own "
        "values are used",
        detector.getNamespace().c_str(), problem.c_str());
    return;
  }
  options->camera_mount = mount;
  options->camera_mount_from_tf = from_tf;
  detector.param("base_frame", options->detector_base_frame, std::string());
  ROS_INFO("Pose graph: camera mount from the detector %s (%s)", detector.getNamespace().c_str(),
           from_tf ? "through tf" : "its camera_mount values");
  if (!options->detector_base_frame.empty() &&
      options->detector_base_frame != options->base_frame) {
    ROS_WARN(
        "Pose graph: the detector's base_frame is '%s', this node's '%s': loops it publishes in "
        "its base frame are left out; set the two alike",
        options->detector_base_frame.c_str(), options->base_frame.c_str());
  }
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
      : options_(options) {
    if (options_.camera_mount_from_tf || options_.mountFromTfWhereKnown()) {
      tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
      tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_);
    }
    corrected_publisher_ = private_node.advertise<nav_msgs::Path>("corrected_path", 1, true);
    odometry_publisher_ = private_node.advertise<nav_msgs::Path>("odometry_path", 1, true);
    verdict_publisher_ = private_node.advertise<PoseGraphLoop>("loop_verdicts", 100);
    rejected_publisher_ =
        private_node.advertise<visualization_msgs::Marker>("rejected_loops", 1, true);
    PoseGraphListener listener;
    listener.step = [this](PoseGraphSession& session, const GraphStep& step) {
      onStep(session, step);
    };
    listener.catch_up = [this](PoseGraphSession& session) {
      publishPaths(session, pathStamp(session));
    };
    listener.failed = [this](const std::string& what) {
      ROS_ERROR_THROTTLE(10.0,
                         "Pose graph: a batch of keyframes and loops threw (%s) and was dropped "
                         "where it was; the graph goes on with the next (%lu so far)",
                         what.c_str(),
                         static_cast<unsigned long>(runtime_ ? runtime_->failures() : 0));
    };
    listener.graph_file = [](const std::string& text, bool problem) {
      if (problem) {
        ROS_WARN("Pose graph: %s", text.c_str());
      } else {
        ROS_INFO("Pose graph: %s", text.c_str());
      }
    };
    runtime_ = std::make_unique<PoseGraphRuntime>(
        std::move(options),
        [this](const std::string& frame, std::string* problem) { return mountOf(frame, problem); },
        listener);
    const std::vector<std::string> robots = options_.robotList();
    if (robots.empty()) {
      keyframe_subscriber_ = node.subscribe("keyframes", 1000, &PoseGraphNode::onKeyframe, this);
      loop_subscriber_ = node.subscribe("loop_closures", 100, &PoseGraphNode::onLoop, this);
    }
    for (size_t robot = 0; robot < robots.size(); ++robot) {
      // ~robot_a/corrected_path for the namespace "/robot_a".
      std::string name = robots[robot];
      while (!name.empty() && name.front() == '/') name.erase(name.begin());
      robot_paths_.push_back(private_node.advertise<nav_msgs::Path>(
          (name.empty() ? "robot_" + std::to_string(robot) : name) + "/corrected_path", 1, true));
      robot_subscribers_.push_back(node.subscribe<Keyframe>(
          robots[robot] + "/keyframes", 1000, [this, robot](const Keyframe::ConstPtr& keyframe) {
            {
              MutexLock lock(robot_maps_mutex_);
              robot_of_map_[keyframe->map_id] = robot;
            }
            onKeyframe(*keyframe);
          }));
      robot_subscribers_.push_back(node.subscribe<LoopClosure>(
          robots[robot] + "/loop_closures", 100,
          [this](const LoopClosure::ConstPtr& loop) { onLoop(*loop); }));
      ROS_INFO(
          "Pose graph: robot %s's keyframes and loops join the graph; its corrected path on "
          "%s",
          robots[robot].c_str(), robot_paths_.back().getTopic().c_str());
    }
    if (options_.publish_tf && options_.tf_rate_hz > 0.0) {
      tf_timer_ = node.createTimer(ros::Duration(1.0 / options_.tf_rate_hz),
                                   [this](const ros::TimerEvent&) { sendCorrection(); });
    }
  }

  ~PoseGraphNode() {
    tf_timer_.stop();
    keyframe_subscriber_.shutdown();
    loop_subscriber_.shutdown();
    for (ros::Subscriber& subscriber : robot_subscribers_) subscriber.shutdown();
    runtime_->stop();
    // At SIGINT ROS has shut its console down before the nodelet is destroyed: say it directly.
    const std::string summary = runtime_->summary();
    if (ros::ok()) {
      ROS_INFO("%s", summary.c_str());
    } else {
      std::fprintf(stderr, "%s\n", summary.c_str());
    }
  }

 private:
  void onKeyframe(const Keyframe& keyframe) { runtime_->push(graphKeyframeFromMsg(keyframe)); }
  void onLoop(const LoopClosure& loop) { runtime_->push(graphLoopFromMsg(loop)); }

  /// On the runtime's worker thread.
  void onStep(PoseGraphSession& session, const GraphStep& step) {
    for (const GraphNotice& notice : step.notices) log(notice);
    for (const GraphLoopVerdict& verdict : step.verdicts) {
      verdict_publisher_.publish(toPoseGraphLoopMsg(verdict, options_.map_frame));
    }
    if (!step.changed) return;
    const ros::Time stamp = pathStamp(session);
    // Without the timer, the correction first: a viewer looking the path up at its stamp then
    // finds it.
    if (options_.publish_tf && options_.tf_rate_hz <= 0.0) sendCorrection(stamp);
    if (step.publish_paths) publishPaths(session, stamp);
  }

  /// Each kind at its own call site, so that throttling one does not silence another.
  static void log(const GraphNotice& notice) {
    const char* text = notice.text.c_str();
    switch (notice.kind) {
      case GraphNotice::Kind::kKeyframeDropped:
        ROS_WARN_THROTTLE(10.0, "Pose graph: %s", text);
        break;
      case GraphNotice::Kind::kNewGraph:
        if (notice.throttle) {
          ROS_WARN_THROTTLE(10.0, "Pose graph: %s", text);
        } else {
          ROS_WARN("Pose graph: %s", text);
        }
        break;
      case GraphNotice::Kind::kNewChain:
        ROS_INFO_THROTTLE(10.0, "Pose graph: %s", text);
        break;
      case GraphNotice::Kind::kLoopBadInput:
        ROS_WARN_THROTTLE(10.0, "Pose graph: %s", text);
        break;
      case GraphNotice::Kind::kLoopRefused:
      case GraphNotice::Kind::kLoopSwitchedOff:
        ROS_WARN("Pose graph: %s", text);
        break;
      case GraphNotice::Kind::kLoopAwaiting:
        ROS_DEBUG("Pose graph: %s", text);
        break;
    }
  }

  /// base_frame <- `frame`: camera_mount, or tf's (latest, kept: a mount does not move). Empty,
  /// with `problem` saying why, while tf does not know it. On the worker thread.
  std::optional<Eigen::Isometry3d> mountOf(const std::string& frame, std::string* problem) {
    const auto known = mounts_.find(frame);
    if (known != mounts_.end()) return known->second;
    if (options_.mountFromTfWhereKnown() && !frame.empty() &&
        tf_buffer_->canTransform(options_.base_frame, frame, ros::Time(0))) {
      const Eigen::Isometry3d mount = tf2::transformToEigen(
          tf_buffer_->lookupTransform(options_.base_frame, frame, ros::Time(0)));
      ROS_INFO("Pose graph: loops in %s turned into %s through tf (camera_mount not set)",
               frame.c_str(), options_.base_frame.c_str());
      return mounts_[frame] = mount;
    }
    if (!options_.camera_mount_from_tf) {
      // Said once per frame: which frame is taken for the camera's.
      const CameraMount& mount = options_.camera_mount;
      if (frames_said_.insert(frame).second) {
        ROS_INFO(
            "Pose graph: loops in '%s' are taken as the camera's and turned into %s with "
            "camera_mount (%.3f, %.3f, %.3f m; roll %.3f, pitch %.3f, yaw %.3f rad)%s",
            frame.c_str(), options_.base_frame.c_str(), mount.x, mount.y, mount.z, mount.roll,
            mount.pitch, mount.yaw,
            options_.mountFromTfWhereKnown() ? ", the default, until tf has that frame"
                                             : "; camera_mount/from_tf looks each loop's frame "
                                               "up in tf instead");
      }
      const Eigen::Isometry3d values = mount.toPose().toIsometry();
      // Not kept when tf may still bring the mount: the next loop asks tf again.
      if (!options_.mountFromTfWhereKnown()) mounts_[frame] = values;
      return values;
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

  /// map_frame -> odometry frame, as the last keyframe left it; stamped tf_future_s ahead of
  /// the clock unless a stamp is given.
  /// map -> each odometry frame the keyframes came in (one per robot sharing the graph).
  void sendCorrection(std::optional<ros::Time> stamp = std::nullopt) {
    std::vector<geometry_msgs::TransformStamped> transforms;
    for (const GraphCorrection& correction : runtime_->corrections()) {
      geometry_msgs::TransformStamped transform =
          tf2::eigenToTransform(correction.map_from_odometry);
      transform.header.stamp =
          stamp ? *stamp : ros::Time::now() + ros::Duration(options_.tf_future_s);
      transform.header.frame_id = options_.map_frame;
      transform.child_frame_id = correction.odometry_frame;
      transforms.push_back(transform);
    }
    if (!transforms.empty()) broadcaster_.sendTransform(transforms);
  }

  static ros::Time pathStamp(const PoseGraphSession& session) {
    ros::Time stamp;
    return session.stampsNs().empty() ? ros::Time::now()
                                      : stamp.fromNSec(session.stampsNs().back());
  }

  void publishPaths(PoseGraphSession& session, const ros::Time& stamp) {
    if (session.pathsPublished()) clearRejected(stamp);
    const PoseGraph& graph = session.graph();
    const std::string& odometry_frame = session.odometryFrame();
    nav_msgs::Path corrected;
    nav_msgs::Path odometry;
    corrected.header.frame_id = options_.map_frame;
    odometry.header.frame_id = odometry_frame;
    corrected.header.stamp = odometry.header.stamp = stamp;
    // Every chain's keyframes are in the map frame; the odometry path is the current chain's,
    // the only one in odometry_frame.
    const std::vector<uint64_t>& ids = graph.ids();
    const std::optional<size_t> current_chain = session.currentChain();
    for (size_t i = 0; i < ids.size(); ++i) {
      ros::Time keyframe_stamp;
      keyframe_stamp.fromNSec(session.stampsNs()[i]);
      corrected.poses.push_back(
          stampedPose(*graph.optimisedPose(ids[i]), options_.map_frame, keyframe_stamp));
      if (graph.chainOf(ids[i]) != current_chain) continue;
      odometry.poses.push_back(
          stampedPose(*graph.odometryPose(ids[i]), odometry_frame, keyframe_stamp));
    }
    corrected_publisher_.publish(corrected);
    odometry_publisher_.publish(odometry);
    publishRobotPaths(session, corrected);
    publishRejected(session, stamp);
  }

  /// Each robot's keyframes of `corrected` (the graph's, in its order), on its own path.
  void publishRobotPaths(const PoseGraphSession& session, const nav_msgs::Path& corrected) {
    if (robot_paths_.empty()) return;
    std::vector<nav_msgs::Path> paths(robot_paths_.size());
    for (nav_msgs::Path& path : paths) path.header = corrected.header;
    {
      MutexLock lock(robot_maps_mutex_);
      const std::vector<uint64_t>& ids = session.graph().ids();
      for (size_t i = 0; i < ids.size() && i < corrected.poses.size(); ++i) {
        const auto robot = robot_of_map_.find(session.keyOf(ids[i]).first);
        if (robot != robot_of_map_.end()) paths[robot->second].poses.push_back(corrected.poses[i]);
      }
    }
    for (size_t robot = 0; robot < paths.size(); ++robot) robot_paths_[robot].publish(paths[robot]);
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

  void publishRejected(const PoseGraphSession& session, const ros::Time& stamp) {
    visualization_msgs::Marker marker = rejectedMarker(stamp);
    marker.type = visualization_msgs::Marker::LINE_LIST;
    marker.action = visualization_msgs::Marker::ADD;
    marker.pose.orientation.w = 1.0;
    marker.scale.x = 0.03;
    marker.color.r = 1.0;
    marker.color.a = 1.0;
    const PoseGraph& graph = session.graph();
    const std::vector<LoopVerdict>& verdicts = graph.loopVerdicts();
    for (size_t k = 0; k < verdicts.size(); ++k) {
      // A loop still awaiting confirmation is not a refusal (yet).
      if (verdicts[k].decision == LoopDecision::kAccepted ||
          verdicts[k].decision == LoopDecision::kAwaitingConfirmation) {
        continue;
      }
      const GraphLoop& loop = session.graphLoops()[k];
      const std::optional<Pose> query =
          session.optimisedPose(loop.map_id, loop.constraint.query_id);
      const std::optional<Pose> match =
          session.optimisedPose(loop.matchMap(), loop.constraint.match_id);
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

  const PoseGraphNodeOptions options_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;  ///< camera_mount/from_tf only.
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::map<std::string, Eigen::Isometry3d> mounts_;  ///< base_frame <- each loop frame seen.
  std::set<std::string> frames_said_;  ///< Loop frames whose camera_mount use was logged.

  ros::Publisher corrected_publisher_;
  ros::Publisher odometry_publisher_;
  ros::Publisher rejected_publisher_;
  ros::Publisher verdict_publisher_;
  tf2_ros::TransformBroadcaster broadcaster_;
  std::unique_ptr<PoseGraphRuntime> runtime_;
  ros::Subscriber keyframe_subscriber_;
  ros::Subscriber loop_subscriber_;
  // robots: each one's subscriptions and corrected path, and which robot each map is.
  std::vector<ros::Subscriber> robot_subscribers_;
  std::vector<ros::Publisher> robot_paths_;
  Mutex robot_maps_mutex_;
  std::map<uint64_t, size_t> robot_of_map_ GUARDED_BY(robot_maps_mutex_);
  ros::Timer tf_timer_;
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
    takeDetectorsMount(getNodeHandle(), &options);
    node_ = std::make_unique<PoseGraphNode>(getNodeHandle(), getPrivateNodeHandle(), options);
  }

  std::unique_ptr<PoseGraphNode> node_;
};

}  // namespace landmark_loop_closure

PLUGINLIB_EXPORT_CLASS(landmark_loop_closure::PoseGraphNodelet, nodelet::Nodelet)
