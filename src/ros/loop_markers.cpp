#include "loop_markers.h"

#include <algorithm>

namespace landmark_loop_closure {

namespace {

constexpr size_t kMaxRejectedLines = 500;  // Only the recent ones: rviz slows down with many.

geometry_msgs::Point toPoint(const Pose& pose) {
  geometry_msgs::Point point;
  point.x = pose.position.x();
  point.y = pose.position.y();
  point.z = pose.position.z();
  return point;
}

std_msgs::ColorRGBA colour(float r, float g, float b, float a) {
  std_msgs::ColorRGBA c;
  c.r = r;
  c.g = g;
  c.b = b;
  c.a = a;
  return c;
}

visualization_msgs::Marker makeMarker(const std::string& frame_id, const ros::Time& stamp,
                                      const std::string& ns, int type, double width) {
  visualization_msgs::Marker marker;
  marker.header.frame_id = frame_id;
  marker.header.stamp = stamp;
  marker.ns = ns;
  marker.id = 0;
  marker.type = type;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  marker.scale.x = width;
  marker.scale.y = width;
  marker.scale.z = width;
  return marker;
}

}  // namespace

LoopMarkers::LoopMarkers(std::string frame_id, double min_score, bool show_rejected)
    : frame_id_(std::move(frame_id)), min_score_(min_score), show_rejected_(show_rejected) {}

void LoopMarkers::addKeyframe(const Pose& pose) { keyframes_.push_back(toPoint(pose)); }

void LoopMarkers::clear() {
  keyframes_.clear();
  loop_ends_.clear();
  loop_colours_.clear();
  unverified_ends_.clear();
  rejected_ends_.clear();
}

void LoopMarkers::addLoop(const AcceptedLoop& loop) {
  if (!loop.verification && !loop.appearance) {
    unverified_ends_.push_back(toPoint(loop.query_pose));
    unverified_ends_.push_back(toPoint(loop.match_pose));
    return;
  }
  loop_ends_.push_back(toPoint(loop.query_pose));
  loop_ends_.push_back(toPoint(loop.match_pose));
  // Green whatever the score (an accepted loop is a right one as far as the node can tell); the
  // score from the threshold to 1 only brightens it.
  const float t = static_cast<float>(
      std::clamp((loop.score - min_score_) / std::max(1e-6, 1.0 - min_score_), 0.0, 1.0));
  const std_msgs::ColorRGBA c = colour(0.1f, 0.55f + 0.45f * t, 0.15f, 1.0f);
  loop_colours_.push_back(c);
  loop_colours_.push_back(c);
}

void LoopMarkers::addRejected(const Pose& query, const Pose& match) {
  if (!show_rejected_) return;
  rejected_ends_.push_back(toPoint(query));
  rejected_ends_.push_back(toPoint(match));
  if (rejected_ends_.size() > 2 * kMaxRejectedLines) {
    rejected_ends_.erase(rejected_ends_.begin(), rejected_ends_.begin() + 2);
  }
}

visualization_msgs::MarkerArray LoopMarkers::toMsg(const ros::Time& stamp) const {
  visualization_msgs::MarkerArray array;
  // rviz marks a display as failed for a list marker without points: an empty namespace is
  // deleted instead (which also clears what it drew before a reset).
  const auto add = [&](visualization_msgs::Marker marker) {
    if (marker.points.empty()) {
      marker.action = visualization_msgs::Marker::DELETE;
      marker.colors.clear();
    }
    array.markers.push_back(std::move(marker));
  };
  visualization_msgs::Marker keyframes =
      makeMarker(frame_id_, stamp, "keyframes", visualization_msgs::Marker::SPHERE_LIST, 0.15);
  keyframes.points = keyframes_;
  keyframes.color = colour(0.2f, 0.5f, 1.0f, 0.9f);
  add(keyframes);

  visualization_msgs::Marker loops =
      makeMarker(frame_id_, stamp, "loops", visualization_msgs::Marker::LINE_LIST, 0.06);
  loops.points = loop_ends_;
  loops.colors = loop_colours_;
  loops.color = colour(0.1f, 0.8f, 0.15f, 1.0f);
  add(loops);

  // Loops published without the geometric check (no usable camera_info): thin and orange.
  visualization_msgs::Marker unverified = makeMarker(frame_id_, stamp, "unverified_loops",
                                                     visualization_msgs::Marker::LINE_LIST, 0.025);
  unverified.points = unverified_ends_;
  unverified.color = colour(1.0f, 0.55f, 0.0f, 1.0f);
  add(unverified);

  if (show_rejected_) {
    visualization_msgs::Marker rejected =
        makeMarker(frame_id_, stamp, "rejected", visualization_msgs::Marker::LINE_LIST, 0.02);
    rejected.points = rejected_ends_;
    rejected.color = colour(0.6f, 0.6f, 0.6f, 0.5f);
    add(rejected);
  }

  visualization_msgs::Marker legend =
      makeMarker(frame_id_, stamp, "legend", visualization_msgs::Marker::TEXT_VIEW_FACING, 0.6);
  if (keyframes_.empty()) {
    legend.action = visualization_msgs::Marker::DELETE;
  } else {
    // Above the middle of the map, where rviz's view is centred, so the line stays in view.
    for (const geometry_msgs::Point& keyframe : keyframes_) {
      legend.pose.position.x += keyframe.x / static_cast<double>(keyframes_.size());
      legend.pose.position.y += keyframe.y / static_cast<double>(keyframes_.size());
      legend.pose.position.z = std::max(legend.pose.position.z, keyframe.z);
    }
    legend.pose.position.z += 1.5;
    legend.color = colour(1.0f, 1.0f, 1.0f, 1.0f);
    legend.text = show_rejected_ ? "blue: keyframes  green: verified loop  orange: unverified  "
                                   "grey: rejected candidate"
                                 : "blue: keyframes  green: verified loop  orange: unverified";
  }
  array.markers.push_back(legend);
  return array;
}

}  // namespace landmark_loop_closure
