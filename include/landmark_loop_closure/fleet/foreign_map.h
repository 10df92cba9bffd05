// One other robot's map as the fleet matcher keeps it (issue 81): its rows in id order and their
// vectors, an HNSW graph over them, and the path scores of the querying run's newest keyframe.
// A small map is scored exactly, every row; from `approximate_from` rows on, only the rows the
// graph finds near the run's last keyframes and a fixed sample of the map (for the calibrated
// decision's tail) are read, so a search reads a bounded number of rows whatever the map's size.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "landmark_loop_closure/database/approximate_index.h"
#include "landmark_loop_closure/database/quantized_vectors.h"
#include "landmark_loop_closure/fleet/shared_keyframe.h"

namespace landmark_loop_closure {

/// How a map of other robot's rows is searched.
struct ForeignSearchOptions {
  /// Rows of one map from which only its nearest rows and a sample are scored (0: never).
  int approximate_from = 2000;
  int nearest = 16;    ///< Rows the graph returns per own keyframe and map.
  int ef_search = 16;  ///< The graph's search effort.
  /// The sample: at most this many blocks of kSampleBlock contiguous keyframes.
  int sample_blocks = 8;
  int neighbors = 16;  ///< HNSW links per row.
  int ef_construction = 64;
};

/// One own keyframe's cosines to one map's rows, kept while the keyframe is among the querying
/// run's last sequence_length: each is computed once.
struct KeyframeCosines {
  std::vector<float> values;    ///< By row position; NaN: not computed (yet).
  size_t computed = 0;          ///< Values that hold a cosine.
  std::vector<size_t> nearest;  ///< Rows the graph found nearest, when it was newest.
  bool searched = false;
};

/// One own keyframe of the querying run: its row and its cosines to each map's rows.
struct QueryKeyframe {
  const uint8_t* row = nullptr;
  KeyframeCosines* cosines = nullptr;
};

/// A row's best path score for the run's newest keyframe.
struct ScoredRow {
  size_t position = 0;  ///< In the order the rows came.
  double score = 0.0;
  bool sampled = false;  ///< In the map's sample: evidence of what a wrong place scores.
};

struct MapScores {
  std::vector<ScoredRow> rows;  ///< Every row with a complete path (exact), or those read.
  /// Rows of the map each sampled row stands for (1 when every row was scored).
  double rows_per_sample = 1.0;
  bool approximate = false;
};

class ForeignMap {
 public:
  static constexpr size_t kSampleBlock = 32;

  ForeignMap(std::string robot, std::string peer, uint64_t ordinal, int dimension,
             const ForeignSearchOptions& search);

  const std::string& robot() const { return robot_; }
  const std::string& peer() const { return peer_; }
  uint64_t ordinal() const { return ordinal_; }
  bool holds(uint64_t id) const { return ids_.count(id) > 0; }
  size_t size() const { return rows_.size(); }
  /// A row as it came, without its vector.
  const SharedKeyframe& row(size_t position) const { return rows_[position]; }

  /// Keeps a validated row (its global_row of the map's dimension), its id not held yet.
  void add(const SharedKeyframe& row);

  /// Each row's best path score (mean cosine along a straight path of the run's keyframes,
  /// newest first in `run`, stepping back through the map's ids at each of `speeds`).
  MapScores score(const std::vector<QueryKeyframe>& run, const std::vector<double>& speeds) const;

  size_t bytes() const;

 private:
  float cosine(const QueryKeyframe& keyframe, size_t position) const;
  /// The path scores of the rows whose id rank is in `ranks` (sorted, unique).
  void scorePaths(const std::vector<QueryKeyframe>& run, const std::vector<double>& speeds,
                  const std::vector<size_t>& ranks, const std::vector<bool>& sampled,
                  MapScores* scores) const;

  std::string robot_;
  std::string peer_;  ///< Who shared it first; only its rows are kept.
  uint64_t ordinal_;  ///< Keeps chain ids of two maps apart.
  ForeignSearchOptions search_;
  std::unique_ptr<QuantizedVectors> vectors_;
  std::unique_ptr<ApproximateIndex> graph_;
  std::vector<SharedKeyframe> rows_;  ///< Without their vectors, in the order they came.
  std::set<uint64_t> ids_;
  /// Row positions in id order (a peer's backlog may come after its newer rows), and each
  /// row's place in it: a path steps back through the map's keyframes as the robot drove them.
  std::vector<size_t> by_id_;
  std::vector<size_t> rank_;
};

}  // namespace landmark_loop_closure
