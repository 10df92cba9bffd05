#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "landmark_loop_closure/common/parameter_table.h"

namespace landmark_loop_closure {

/// How the database searches its global descriptors.
struct IndexOptions {
  /// "exact": every stored descriptor is compared; "approximate": an HNSW graph (faiss) finds the
  /// shortlist; "auto": the graph is kept up to date from the start and used once the database
  /// holds approximate_from keyframes (exact below, where it is fast enough).
  std::string type = "auto";
  int approximate_from = 20000;
  int neighbors = 16;        ///< HNSW links per node (M): memory and recall grow with it.
  int ef_construction = 64;  ///< HNSW candidate list while inserting: graph quality.
  int ef_search = 256;       ///< HNSW candidate list while searching: recall against time.

  bool buildsGraph() const { return type != "exact"; }
  /// Settings a saved graph must match to be reused (ef_search may differ).
  std::string graphIdentity() const;
  /// Keys under database/index/, documented in config/default.yaml.
  static const ParameterTable<IndexOptions>& parameters();
  std::string validate() const;
};

/// An HNSW graph over L2-normalised vectors, searched by inner product (cosine). Positions are
/// insertion order. Not thread-safe: search() sets the graph's search effort, so one thread at a
/// time (the database's owner).
class ApproximateIndex {
 public:
  ApproximateIndex(int dimension, int neighbors, int ef_construction);
  ~ApproximateIndex();
  ApproximateIndex(const ApproximateIndex&) = delete;
  ApproximateIndex& operator=(const ApproximateIndex&) = delete;

  /// Appends one vector of `dimension` floats; its position is the previous size().
  void add(const float* vector);
  size_t size() const;
  int dimension() const { return dimension_; }

  /// Up to `k` (position, inner product) pairs, best first.
  std::vector<std::pair<size_t, float>> search(const float* query, size_t k, int ef_search) const;

  /// The graph and its vectors as bytes (faiss's own layout) and back. fromBytes throws
  /// std::runtime_error when the bytes are not an HNSW index of this dimension and shape.
  std::vector<uint8_t> toBytes() const;
  static std::unique_ptr<ApproximateIndex> fromBytes(std::vector<uint8_t> bytes, int dimension,
                                                     int neighbors);

  /// Heap bytes: the vectors and the links.
  size_t bytes() const;

 private:
  struct Graph;
  ApproximateIndex(int dimension, std::unique_ptr<Graph> graph);

  int dimension_;
  std::unique_ptr<Graph> graph_;
};

}  // namespace landmark_loop_closure
