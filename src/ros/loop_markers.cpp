#include "loop_markers.h"

#include <algorithm>

namespace landmark_loop_closure {

namespace {

constexpr size_t kMaxRejectedLines = 500;

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
                                      const std::string& ns, int id, int type, double width) {
  visualization_msgs::Marker marker;
  marker.header.frame_id = frame_id;
  marker.header.stamp = stamp;
  marker.ns = ns;
  marker.id = id;
  marker.type = type;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  marker.scale.x = width;
  marker.scale.y = width;
  marker.scale.z = width;
  return marker;
}

// rviz marks a display as failed for a list marker without points: one with nothing to draw is
// sent as DELETE instead.
visualization_msgs::Marker deletedIfEmpty(visualization_msgs::Marker marker) {
  if (marker.points.empty()) {
    marker.action = visualization_msgs::Marker::DELETE;
    marker.colors.clear();
  }
  return marker;
}

}  // namespace

void LoopMarkers::Layer::add(const geometry_msgs::Point& point,
                             const std_msgs::ColorRGBA* point_colour) {
  if (points.empty() || points.back().size() >= kChunkPoints) {
    points.emplace_back();
    colours.emplace_back();
    changed.push_back(true);
    points.back().reserve(kChunkPoints);
  }
  points.back().push_back(point);
  if (per_point_colour && point_colour) colours.back().push_back(*point_colour);
  changed.back() = true;
}

void LoopMarkers::Layer::clear() {
  points.clear();
  colours.clear();
  changed.clear();
}

void LoopMarkers::Layer::markers(const std::string& frame_id, const ros::Time& stamp,
                                 bool only_changed, visualization_msgs::MarkerArray* array) const {
  if (points.empty() && !only_changed) {
    array->markers.push_back(deletedIfEmpty(makeMarker(frame_id, stamp, ns, 0, type, width)));
    return;
  }
  for (size_t chunk = 0; chunk < points.size(); ++chunk) {
    if (only_changed && !changed[chunk]) continue;
    visualization_msgs::Marker marker =
        makeMarker(frame_id, stamp, ns, static_cast<int>(chunk), type, width);
    marker.points = points[chunk];
    marker.color = colour;
    if (per_point_colour) marker.colors = colours[chunk];
    array->markers.push_back(deletedIfEmpty(std::move(marker)));
  }
}

LoopMarkers::LoopMarkers(std::string frame_id, double min_score, bool show_rejected)
    : min_score_(min_score), show_rejected_(show_rejected), frame_id_(std::move(frame_id)) {
  using visualization_msgs::Marker;
  keyframes_.ns = "keyframes";
  keyframes_.type = Marker::SPHERE_LIST;
  keyframes_.width = 0.15;
  keyframes_.colour = colour(0.2f, 0.5f, 1.0f, 0.9f);
  loops_.ns = "loops";
  loops_.type = Marker::LINE_LIST;
  loops_.width = 0.06;
  loops_.colour = colour(0.1f, 0.8f, 0.15f, 1.0f);
  loops_.per_point_colour = true;
  // Loops published without the geometric check (no usable camera_info): thin and orange.
  unverified_.ns = "unverified_loops";
  unverified_.type = Marker::LINE_LIST;
  unverified_.width = 0.025;
  unverified_.colour = colour(1.0f, 0.55f, 0.0f, 1.0f);
}

void LoopMarkers::setFrameId(const std::string& frame_id) {
  MutexLock lock(mutex_);
  frame_id_ = frame_id;
}

void LoopMarkers::addKeyframe(const Pose& pose) {
  MutexLock lock(mutex_);
  const geometry_msgs::Point point = toPoint(pose);
  keyframes_.add(point, nullptr);
  sum_x_ += point.x;
  sum_y_ += point.y;
  max_z_ = keyframe_count_ == 0 ? point.z : std::max(max_z_, point.z);
  ++keyframe_count_;
  legend_changed_ = true;
}

void LoopMarkers::clear() {
  MutexLock lock(mutex_);
  keyframes_.clear();
  loops_.clear();
  unverified_.clear();
  rejected_ends_.clear();
  rejected_changed_ = false;  // The DELETEALL of the next changes() removes it.
  sum_x_ = sum_y_ = max_z_ = 0.0;
  keyframe_count_ = 0;
  cleared_ = true;
}

void LoopMarkers::addLoop(const AcceptedLoop& loop) {
  MutexLock lock(mutex_);
  // A line's two ends always share a chunk: chunks hold an even number of points.
  if (!loop.verification && !loop.appearance) {
    unverified_.add(toPoint(loop.query_pose), nullptr);
    unverified_.add(toPoint(loop.match_pose), nullptr);
    return;
  }
  // Green whatever the score (an accepted loop is a right one as far as the node can tell); the
  // score from the threshold to 1 only brightens it.
  const float t = static_cast<float>(
      std::clamp((loop.score - min_score_) / std::max(1e-6, 1.0 - min_score_), 0.0, 1.0));
  const std_msgs::ColorRGBA c = colour(0.1f, 0.55f + 0.45f * t, 0.15f, 1.0f);
  loops_.add(toPoint(loop.query_pose), &c);
  loops_.add(toPoint(loop.match_pose), &c);
}

void LoopMarkers::addRejected(const Pose& query, const Pose& match) {
  if (!show_rejected_) return;
  MutexLock lock(mutex_);
  rejected_ends_.push_back(toPoint(query));
  rejected_ends_.push_back(toPoint(match));
  if (rejected_ends_.size() > 2 * kMaxRejectedLines) {
    rejected_ends_.erase(rejected_ends_.begin(), rejected_ends_.begin() + 2);
  }
  rejected_changed_ = true;
}

visualization_msgs::Marker LoopMarkers::legend(const ros::Time& stamp) const {
  visualization_msgs::Marker legend =
      makeMarker(frame_id_, stamp, "legend", 0, visualization_msgs::Marker::TEXT_VIEW_FACING, 0.6);
  if (keyframe_count_ == 0) {
    legend.action = visualization_msgs::Marker::DELETE;
    return legend;
  }
  // Above the middle of the map, where rviz's view is centred, so the line stays in view.
  legend.pose.position.x = sum_x_ / static_cast<double>(keyframe_count_);
  legend.pose.position.y = sum_y_ / static_cast<double>(keyframe_count_);
  legend.pose.position.z = max_z_ + 1.5;
  legend.color = colour(1.0f, 1.0f, 1.0f, 1.0f);
  legend.text = show_rejected_ ? "blue: keyframes  green: verified loop  orange: unverified  "
                                 "grey: rejected candidate"
                               : "blue: keyframes  green: verified loop  orange: unverified";
  return legend;
}

visualization_msgs::Marker LoopMarkers::rejected(const ros::Time& stamp) const {
  visualization_msgs::Marker rejected =
      makeMarker(frame_id_, stamp, "rejected", 0, visualization_msgs::Marker::LINE_LIST, 0.02);
  rejected.points = rejected_ends_;
  rejected.color = colour(0.6f, 0.6f, 0.6f, 0.5f);
  return deletedIfEmpty(std::move(rejected));
}

visualization_msgs::MarkerArray LoopMarkers::changes(const ros::Time& stamp) {
  MutexLock lock(mutex_);
  visualization_msgs::MarkerArray array;
  if (cleared_) {
    visualization_msgs::Marker everything;
    everything.header.frame_id = frame_id_;
    everything.header.stamp = stamp;
    everything.action = visualization_msgs::Marker::DELETEALL;
    array.markers.push_back(everything);
  }
  for (Layer* layer : {&keyframes_, &loops_, &unverified_}) {
    layer->markers(frame_id_, stamp, true, &array);
    std::fill(layer->changed.begin(), layer->changed.end(), false);
  }
  if (show_rejected_ && rejected_changed_) array.markers.push_back(rejected(stamp));
  if (legend_changed_ && keyframe_count_ > 0) array.markers.push_back(legend(stamp));
  rejected_changed_ = legend_changed_ = cleared_ = false;
  return array;
}

visualization_msgs::MarkerArray LoopMarkers::snapshot(const ros::Time& stamp) const {
  MutexLock lock(mutex_);
  visualization_msgs::MarkerArray array;
  for (const Layer* layer : {&keyframes_, &loops_, &unverified_}) {
    layer->markers(frame_id_, stamp, false, &array);
  }
  if (show_rejected_) array.markers.push_back(rejected(stamp));
  array.markers.push_back(legend(stamp));
  return array;
}

}  // namespace landmark_loop_closure
