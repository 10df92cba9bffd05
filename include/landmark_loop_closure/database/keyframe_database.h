#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/database/approximate_index.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

struct KeyframeRecord {
  uint64_t id = 0;
  uint32_t session = 0;  ///< The run that stored it; a loaded database holds earlier ones.
  double stamp = 0.0;    ///< Seconds.
  Pose pose;             ///< In the odometry frame.
  PathLength path;       ///< Odometry path travelled up to this keyframe.
  ImageDescriptor descriptor;
  LocalFeatures local_features;  ///< For geometric verification; empty when it is off.
  /// Optional small grey image for debug pictures, JPEG-compressed (about 4 KB instead of 19);
  /// empty when thumbnails are off. encodeThumbnail / decodeThumbnail.
  std::vector<uint8_t> thumbnail_jpeg;
};

/// JPEG bytes of an 8-bit grey image (quality 90); empty for an empty image.
std::vector<uint8_t> encodeThumbnail(const cv::Mat& grey);
/// The grey image back; empty when `jpeg` is empty or cannot be decoded.
cv::Mat decodeThumbnail(const std::vector<uint8_t>& jpeg);

struct DatabaseOptions {
  int exclude_recent_keyframes = 20;     ///< The most recent N keyframes are never candidates.
  double exclude_recent_seconds = 10.0;  ///< Nor are keyframes closer in time than this.
  int min_size = 30;                     ///< No search before the database holds this many.
  int top_k = 10;                        ///< Candidates returned per query.
  /// Database bytes (KeyframeDatabase::bytes) past which keyframes are searched but no longer
  /// stored, in MB; 0: no limit.
  double memory_budget_mb = 0.0;
  /// Search structure. Whether a graph is kept and its shape (neighbors, ef_construction) are
  /// fixed when the database is made; at query time type "exact" searches exactly even when a
  /// graph is kept, and approximate_from and ef_search apply.
  IndexOptions index;

  /// Keys under database/, documented in config/default.yaml.
  static const ParameterTable<DatabaseOptions>& parameters();
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
  bool approximate = false;           ///< The HNSW graph found the candidates.
};

/// Keyframes in insertion order with cosine search over their global descriptors: exact, or
/// through an HNSW graph (IndexOptions). Not thread-safe: one owner (the detector's worker thread)
/// reads and writes it. Movable, not copyable (the graph is large).
class KeyframeDatabase {
 public:
  explicit KeyframeDatabase(int global_dimension, IndexOptions index = {});
  KeyframeDatabase(KeyframeDatabase&&) noexcept;
  KeyframeDatabase& operator=(KeyframeDatabase&&) noexcept;
  ~KeyframeDatabase();

  /// Stores a keyframe. Throws std::invalid_argument, storing nothing, when its id is not greater
  /// than the last id or its global descriptor has the wrong length.
  void add(KeyframeRecord keyframe);

  /// `session`: the querying run; only its own newest keyframes count as recent (the last ones
  /// of a loaded earlier run are not). Throws std::invalid_argument for a descriptor of the wrong
  /// length. With the graph on, the exclusion windows are applied to its shortlist, which is
  /// widened by the number of excluded keyframes (exact search when more than 2000 are excluded).
  QueryResult query(const std::vector<float>& global, double stamp, const DatabaseOptions& options,
                    uint32_t session = 0) const;
  /// Whether keyframe `index` lies outside a query's exclusion windows, as query() decides.
  bool eligible(size_t index, double stamp, const DatabaseOptions& options,
                uint32_t session = 0) const;

  int globalDimension() const { return global_dimension_; }
  size_t size() const { return keyframes_.size(); }
  bool empty() const { return keyframes_.empty(); }
  const KeyframeRecord& at(size_t index) const { return keyframes_.at(index); }
  /// nullptr when no keyframe has this id.
  const KeyframeRecord* findById(uint64_t id) const;
  /// Heap bytes of the stored keyframes (descriptors, thumbnails, records) and the graph; O(1).
  size_t bytes() const;

  const IndexOptions& indexOptions() const { return index_options_; }
  /// The HNSW graph; nullptr when the index type is exact.
  const ApproximateIndex* graph() const { return graph_.get(); }
  /// Switches the search structure. `graph`: one built over exactly these keyframes (a loaded
  /// file's), or nullptr to build it here (slow: about 0.5 ms per 1000-value keyframe). Throws
  /// std::invalid_argument when `graph` does not hold one vector per keyframe.
  void setIndex(const IndexOptions& index, std::unique_ptr<ApproximateIndex> graph = nullptr);

 private:
  /// Keyframes at or past this position are the querying session's newest: never candidates.
  size_t searchEnd(const DatabaseOptions& options, uint32_t session) const;

  int global_dimension_;
  IndexOptions index_options_;
  /// A deque: growing never moves the stored keyframes (a vector would copy them all, since
  /// cv::Mat's move may throw, stalling the worker for seconds at 100 000 keyframes).
  std::deque<KeyframeRecord> keyframes_;
  std::vector<double> stamps_;  ///< keyframes_[i].stamp, contiguous for the exclusion scan.
  size_t content_bytes_ = 0;    ///< Heap bytes the records point to (descriptors, features).
  std::unique_ptr<ApproximateIndex> graph_;
};

}  // namespace landmark_loop_closure
