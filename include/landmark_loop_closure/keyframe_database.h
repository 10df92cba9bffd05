#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/descriptor.h"
#include "landmark_loop_closure/geometric_verification.h"
#include "landmark_loop_closure/pose.h"

namespace landmark_loop_closure {

struct KeyframeRecord {
  uint64_t id = 0;
  uint32_t session = 0;  ///< The run that stored it; a loaded database holds earlier ones.
  double stamp = 0.0;    ///< Seconds.
  Pose pose;           ///< In the odometry frame.
  PathLength path;     ///< Odometry path travelled up to this keyframe.
  ImageDescriptor descriptor;
  LocalFeatures local_features;  ///< For geometric verification; empty when it is off.
  cv::Mat thumbnail;             ///< Optional small grey image for debug pictures; may be empty.
};

struct DatabaseOptions {
  int exclude_recent_keyframes = 20;     ///< The most recent N keyframes are never candidates.
  double exclude_recent_seconds = 10.0;  ///< Nor are keyframes closer in time than this.
  int min_size = 30;                     ///< No search before the database holds this many.
  int top_k = 10;                        ///< Candidates returned per query.

  std::string validate() const;
};

enum class QueryStatus {
  kSearched,
  kDatabaseTooSmall,  ///< Fewer than min_size keyframes stored.
  kAllExcluded,       ///< Every stored keyframe lies inside the exclusion window.
};

const char* toString(QueryStatus status);

struct Candidate {
  size_t index = 0;  ///< Position in the database.
  uint64_t id = 0;
  double global_score = 0.0;  ///< Cosine similarity of the global descriptors.
};

struct QueryResult {
  QueryStatus status = QueryStatus::kDatabaseTooSmall;
  std::vector<Candidate> candidates;  ///< Best first, at most top_k.
  size_t searched = 0;                ///< Keyframes outside the exclusion window.
};

/// Keyframes in insertion order with exact cosine search over their global descriptors.
/// Not thread-safe: one owner (the detector's worker thread) reads and writes it.
class KeyframeDatabase {
 public:
  explicit KeyframeDatabase(int global_dimension);

  /// Stores a keyframe. Throws std::invalid_argument, storing nothing, when its id is not greater
  /// than the last id or its global descriptor has the wrong length.
  void add(KeyframeRecord keyframe);

  /// `session`: the querying run; only its own newest keyframes count as recent (the last ones
  /// of a loaded earlier run are not).
  QueryResult query(const std::vector<float>& global, double stamp, const DatabaseOptions& options,
                    uint32_t session = 0) const;

  int globalDimension() const { return global_dimension_; }
  size_t size() const { return keyframes_.size(); }
  bool empty() const { return keyframes_.empty(); }
  const KeyframeRecord& at(size_t index) const { return keyframes_.at(index); }
  /// nullptr when no keyframe has this id.
  const KeyframeRecord* findById(uint64_t id) const;
  /// Heap bytes of the stored keyframes (descriptors, thumbnails, records).
  size_t bytes() const;

 private:
  int global_dimension_;
  std::vector<KeyframeRecord> keyframes_;
};

}  // namespace landmark_loop_closure
