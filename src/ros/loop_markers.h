#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <visualization_msgs/MarkerArray.h>

#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/core/loop_detector.h"

namespace landmark_loop_closure {

/// What rviz shows: keyframe positions (blue), verified loops green (brighter the higher their
/// score), loops published without the geometric check orange, optionally rejected candidates
/// grey, and a legend saying so above the middle of the map. Every marker is one rviz accepts: a
/// namespace with nothing to draw is sent as DELETE, never as an empty point list.
///
/// Drawn incrementally, so a keyframe costs the same on a map of any size: points are kept in
/// chunks of kChunkPoints, one marker id per chunk, and changes() sends only the chunks that
/// changed since the last call; snapshot() sends everything (for a viewer that connects later).
/// Thread-safe: the worker adds, a subscriber's connection asks for a snapshot.
class LoopMarkers {
 public:
  static constexpr size_t kChunkPoints = 1000;

  LoopMarkers(std::string frame_id, double min_score, bool show_rejected);

  void addKeyframe(const Pose& pose);
  void addLoop(const AcceptedLoop& loop);
  void addRejected(const Pose& query, const Pose& match);
  void setFrameId(const std::string& frame_id);
  /// Forgets everything drawn (a database loaded or reset); the next changes() deletes it in rviz.
  void clear();

  /// The markers changed since the last changes() (after clear(): a DELETEALL first).
  visualization_msgs::MarkerArray changes(const ros::Time& stamp);
  /// Every marker: what a viewer that connects now needs.
  visualization_msgs::MarkerArray snapshot(const ros::Time& stamp) const;

 private:
  /// One namespace's points, in chunks of kChunkPoints (line lists: an even number per chunk).
  struct Layer {
    std::string ns;
    int type = 0;
    double width = 0.0;
    std_msgs::ColorRGBA colour;
    bool per_point_colour = false;
    std::vector<std::vector<geometry_msgs::Point>> points;
    std::vector<std::vector<std_msgs::ColorRGBA>> colours;
    std::vector<bool> changed;  ///< Per chunk, since the last changes().

    void add(const geometry_msgs::Point& point, const std_msgs::ColorRGBA* point_colour);
    void clear();
    void markers(const std::string& frame_id, const ros::Time& stamp, bool only_changed,
                 visualization_msgs::MarkerArray* array) const;
  };

  visualization_msgs::Marker legend(const ros::Time& stamp) const REQUIRES(mutex_);
  visualization_msgs::Marker rejected(const ros::Time& stamp) const REQUIRES(mutex_);

  const double min_score_;
  const bool show_rejected_;
  mutable Mutex mutex_;
  std::string frame_id_ GUARDED_BY(mutex_);
  Layer keyframes_ GUARDED_BY(mutex_);
  Layer loops_ GUARDED_BY(mutex_);
  Layer unverified_ GUARDED_BY(mutex_);
  /// Rejected candidates: only the most recent kMaxRejectedLines (rviz slows down with many),
  /// one marker that is re-sent whole when it changes (its size is bounded).
  std::vector<geometry_msgs::Point> rejected_ends_ GUARDED_BY(mutex_);
  bool rejected_changed_ GUARDED_BY(mutex_) = false;
  // The legend sits above the middle of the map: running sums, not a pass over every keyframe.
  double sum_x_ GUARDED_BY(mutex_) = 0.0;
  double sum_y_ GUARDED_BY(mutex_) = 0.0;
  double max_z_ GUARDED_BY(mutex_) = 0.0;
  size_t keyframe_count_ GUARDED_BY(mutex_) = 0;
  bool legend_changed_ GUARDED_BY(mutex_) = false;
  bool cleared_ GUARDED_BY(mutex_) = false;
};

}  // namespace landmark_loop_closure
