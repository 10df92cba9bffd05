#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <list>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <opencv2/core.hpp>

#include "landmark_loop_closure/database/approximate_index.h"
#include "landmark_loop_closure/database/row_projection.h"
#include "landmark_loop_closure/descriptors/descriptor.h"
#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {

/// What search keeps in RAM of every keyframe besides its global descriptor.
struct KeyframeSummary {
  uint64_t id = 0;
  /// Its pose's odometry frame: the run that stored it, or the part of that run after its
  /// odometry was re-initialised; a loaded database holds earlier ones.
  uint32_t session = 0;
  double stamp = 0.0;  ///< Seconds.
  Pose pose;           ///< In the odometry frame.
  PathLength path;     ///< Odometry path travelled up to this keyframe.
};

struct KeyframeRecord : KeyframeSummary {
  /// The image's stamp exactly, in nanoseconds since the epoch, as the camera driver gave it
  /// (`stamp` in seconds is a double: about 0.2 us apart at today's times). 0 when unknown: read
  /// from a map written before maps kept it, it is `stamp` rounded.
  int64_t stamp_ns = 0;
  /// The global vector is the database's 8-bit copy of the described one once stored.
  ImageDescriptor descriptor;
  LocalFeatures local_features;  ///< For geometric verification; empty when it is off.
  /// Optional small grey image for debug pictures, compressed (WebP; maps written before kept
  /// JPEG): about 2 KB instead of 19. Empty when thumbnails are off. encodeThumbnail /
  /// decodeThumbnail.
  std::vector<uint8_t> thumbnail;
};

/// WebP bytes of an 8-bit grey image (quality 30: ~1.8 KB at 160x120); empty for an empty
/// image.
std::vector<uint8_t> encodeThumbnail(const cv::Mat& grey);
/// The grey image back (WebP or JPEG); empty when `bytes` is empty or cannot be decoded.
cv::Mat decodeThumbnail(const std::vector<uint8_t>& bytes);
/// A keyframe's thumbnail as the detector stores it: the image in grey at 160x120, encoded.
std::vector<uint8_t> makeThumbnail(const cv::Mat& image);

struct DatabaseOptions {
  int exclude_recent_keyframes = 20;     ///< The most recent N keyframes are never candidates.
  double exclude_recent_seconds = 10.0;  ///< Nor are keyframes closer in time than this.
  int min_size = 30;                     ///< No search before the database holds this many.
  int top_k = 10;                        ///< Candidates returned per query.
  /// RAM of the database (KeyframeDatabase::bytes) past which keyframes are searched but no
  /// longer stored, in MB; 0: no limit.
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
  kMapDamaged,        ///< The map's search rows failed their check: nothing is searched.
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
  /// The HNSW graph, or the rows' projections (IndexOptions::coarse_from), found the candidates.
  bool approximate = false;
};

/// Reads a stored keyframe whole (the map file's record); nullopt when it cannot be read.
using RecordReader = std::function<std::optional<KeyframeRecord>(uint64_t id)>;

/// Keyframes in insertion order with cosine search over their global descriptors, held in RAM as
/// 8-bit rows (QuantizedVectors): exact, or through an HNSW graph over those rows (IndexOptions).
/// The rest of each keyframe (landmarks, keypoints, thumbnail) is held in RAM too, unless
/// readRecordsFrom() gives a reader (the map file): then only the newest and the most recently
/// read records stay, and search keeps about 4.5 KB per keyframe whatever the record's size.
/// Not thread-safe, reads included (records are cached): one owner (the detector's worker) reads
/// and writes it. Movable, not copyable.
class KeyframeDatabase {
 public:
  explicit KeyframeDatabase(int global_dimension, IndexOptions index = {});
  KeyframeDatabase(KeyframeDatabase&&) noexcept;
  KeyframeDatabase& operator=(KeyframeDatabase&&) noexcept;
  ~KeyframeDatabase();

  /// Stores a keyframe. Throws std::invalid_argument, storing nothing, when its id is not greater
  /// than the last id or its global descriptor has the wrong length.
  void add(KeyframeRecord keyframe);
  /// As add(), for a keyframe the map file could not take (disk full, file gone): with a reader
  /// its record stays in RAM instead of the cache, so it is still compared, never "unreadable".
  void addUnstored(KeyframeRecord keyframe);
  /// Stores a keyframe known only by its summary and encoded global row (QuantizedVectors), its
  /// record left to the reader: how a map file is opened. Throws as add() does.
  void addSummary(const KeyframeSummary& summary, const uint8_t* vector_row, size_t row_bytes);
  /// Stores `count` keyframes of a map at once, into an empty database: their rows (`count` rows
  /// one after the other, as QuantizedVectors encodes them) used in place, kept readable by
  /// `owner` (the mapped file), their summaries `summary_of(0..count-1)`. Throws as add() does.
  /// `stride`: bytes from one row to the next (0: rows back to back).
  void addSaved(std::shared_ptr<const void> owner, const uint8_t* rows, size_t count,
                const std::function<KeyframeSummary(size_t)>& summary_of, size_t stride = 0);
  /// From now on records are read by `reader` and RAM keeps at most `cached_records` of them (the
  /// newest ones and the latest read); the records held so far are dropped.
  void readRecordsFrom(RecordReader reader, size_t cached_records);

  /// `session`: the querying one; only its own newest keyframes count as recent (the last ones
  /// of an earlier session are not: a loaded run, or the odometry before it was re-initialised).
  /// Throws std::invalid_argument for a descriptor of the wrong length. With the graph on, the
  /// exclusion windows are applied to its shortlist, which is widened by the number of excluded
  /// keyframes (exact search when more than 2000 are excluded).
  QueryResult query(const std::vector<float>& global, double stamp, const DatabaseOptions& options,
                    uint32_t session = 0) const;
  /// Whether keyframe `index` lies outside a query's exclusion windows, as query() decides.
  bool eligible(size_t index, double stamp, const DatabaseOptions& options,
                uint32_t session = 0) const;
  /// Cosine of `global` with keyframe `index`'s descriptor, as query() scores it.
  double similarity(const std::vector<float>& global, size_t index) const;
  /// A descriptor encoded as the search compares it, for many similarity() calls (sequence
  /// matching scores each query keyframe against hundreds of keyframes).
  struct EncodedQuery {
    std::vector<uint8_t> row;
  };
  EncodedQuery encode(const std::vector<float>& global) const;
  double similarity(const EncodedQuery& query, size_t index) const;
  /// The same for several keyframes, the query encoded once.
  std::vector<double> similarities(const std::vector<float>& global,
                                   const std::vector<size_t>& indices) const;

  int globalDimension() const { return vectors_->dimension(); }
  size_t size() const { return summaries_.size(); }
  bool empty() const { return summaries_.empty(); }
  const KeyframeSummary& summary(size_t index) const { return summaries_.at(index); }
  /// Keyframe `index` whole: from RAM, or read through the reader (disk); nullptr when the reader
  /// cannot read it (a damaged record).
  std::shared_ptr<const KeyframeRecord> record(size_t index) const;
  /// The position of the keyframe with this id.
  std::optional<size_t> indexOf(uint64_t id) const;
  /// The keyframe with this id; nullptr when there is none (or its record cannot be read).
  const KeyframeSummary* findSummary(uint64_t id) const;
  std::shared_ptr<const KeyframeRecord> findRecord(uint64_t id) const;
  /// Heap bytes held: summaries, vectors, graph, records in RAM; O(1).
  size_t bytes() const;
  /// What bytes() grows by per keyframe on average (records read from a map, so none in RAM),
  /// its row `row_stride` bytes (0: rowBytes(); a map's rows file: its entries).
  size_t bytesPerKeyframe(size_t row_stride = 0) const;
  /// Records read through the reader so far (not found in RAM).
  size_t recordReads() const { return record_reads_; }

  const IndexOptions& indexOptions() const { return index_options_; }
  /// The HNSW graph; nullptr when the index type is exact.
  const ApproximateIndex* graph() const { return graph_.get(); }
  /// Switches the search structure. `graph`: one built over the first keyframes of this database
  /// (a saved one; the keyframes after it are linked in here), or nullptr to build it here (slow:
  /// about 1 ms per keyframe). Throws std::invalid_argument when `graph` holds more keyframes, or
  /// is not over this database's vectors.
  void setIndex(const IndexOptions& index, std::unique_ptr<ApproximateIndex> graph = nullptr);
  /// The vectors a graph loaded for this database must be built over (ApproximateIndex::load).
  const QuantizedVectors* vectors() const { return vectors_.get(); }

 private:
  void addEntry(const KeyframeSummary& summary);
  /// The query's projection when the rows' projections rank this search (IndexOptions::
  /// coarse_from, the first `end` rows projected, more than coarse_candidates of them searched);
  /// nullopt: score every row exactly.
  std::optional<RowProjection::Projected> coarseProjection(const IndexOptions& index,
                                                           const std::vector<uint8_t>& row,
                                                           size_t end, size_t searched) const;
  /// Learns the projection from the map's first coarse_from rows (and projects every row) when
  /// there is none yet and the map holds `rows` >= coarse_from.
  void learnProjectionOnceDue(size_t rows);
  /// Exact search may read row projections: type auto, coarse_from set, below approximate_from.
  bool wantsProjection() const {
    return index_options_.type == "auto" && index_options_.coarse_from > 0 &&
           vectors_->size() < static_cast<size_t>(index_options_.approximate_from);
  }
  void cache(std::shared_ptr<const KeyframeRecord> record) const;
  /// Keyframes at or past this position are the querying session's newest: never candidates.
  size_t searchEnd(const DatabaseOptions& options, uint32_t session) const;

  IndexOptions index_options_;
  void add(KeyframeRecord keyframe, bool unstored);

  /// A deque: growing never moves the stored summaries (no copy of them all at a doubling).
  std::deque<KeyframeSummary> summaries_;
  std::vector<double> stamps_;  ///< summaries_[i].stamp, contiguous for the exclusion scan.
  std::unique_ptr<QuantizedVectors> vectors_;  ///< Held by pointer: the graph refers to it.
  std::unique_ptr<ApproximateIndex> graph_;
  /// The rows projected onto their leading directions while the map is below approximate_from
  /// with type auto (exact search reads them past coarse_from), learned when the map reaches
  /// coarse_from; a map opened past approximate_from is not projected.
  std::unique_ptr<RowProjection> projection_;

  /// Without a reader: every record, by position.
  std::deque<std::shared_ptr<const KeyframeRecord>> records_;
  mutable size_t record_bytes_ = 0;  ///< Heap bytes of the records in RAM.
  /// With a reader: the newest and latest read records, least recently used first.
  RecordReader reader_;
  size_t cached_records_ = 0;
  mutable std::list<std::shared_ptr<const KeyframeRecord>> cache_order_;
  mutable std::unordered_map<uint64_t, decltype(cache_order_)::iterator> cache_;
  /// With a reader: records the map file could not take (addUnstored), by id.
  std::unordered_map<uint64_t, std::shared_ptr<const KeyframeRecord>> unstored_;
  mutable size_t record_reads_ = 0;
};

/// Heap bytes a record points to (descriptor, features, thumbnail).
size_t recordBytes(const KeyframeRecord& keyframe);

}  // namespace landmark_loop_closure
