#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

namespace landmark_loop_closure {

/// How the database searches its global descriptors.
struct IndexOptions {
  /// "exact": every stored descriptor is compared; "approximate": an HNSW graph (hnswlib) finds the
  /// shortlist; "auto": the graph is kept up to date from the start and used once the database
  /// holds approximate_from keyframes (exact below, where it is fast enough).
  std::string type = "auto";
  int approximate_from = 20000;
  int neighbors = 16;         ///< HNSW links per node (M): memory and recall grow with it.
  int ef_construction = 128;  ///< HNSW candidate list while inserting: graph quality.
  int ef_search = 256;        ///< HNSW candidate list while searching: recall against time.
  /// auto: below approximate_from, a map of at least this many keyframes is searched through
  /// its rows' projections (RowProjection, learned when the map reaches it), only the
  /// coarse_candidates best scored exactly; 0: every keyframe scored exactly there.
  int coarse_from = 5000;
  int coarse_candidates = 400;

  bool buildsGraph() const { return type != "exact"; }
  /// Settings a saved graph must match to be reused (ef_search may differ).
  std::string graphIdentity() const;
  /// Keys under advanced/database/index/, documented in config/default.yaml.
  static const ParameterTable<IndexOptions>& parameters();
  std::string validate() const;
};

/// An HNSW graph (hnswlib) over the rows of a QuantizedVectors, searched by inner product
/// (cosine). The graph holds row numbers, not copies of the vectors: about 200 bytes per row with
/// 16 neighbours. Positions are row numbers. Not thread-safe: one thread at a time (the database's
/// owner); search() sets the graph's search effort.
class ApproximateIndex {
 public:
  /// `vectors` must outlive the index; rows are added to the graph by add().
  ApproximateIndex(const QuantizedVectors* vectors, int neighbors, int ef_construction);
  ~ApproximateIndex();
  ApproximateIndex(const ApproximateIndex&) = delete;
  ApproximateIndex& operator=(const ApproximateIndex&) = delete;

  /// Links the next row of the vectors (row size()) into the graph.
  void add();
  /// Reads its rows from `vectors` from now on: vectors whose first size() rows are the same
  /// (a graph built over a snapshot, handed to the database it was taken from).
  void rebind(const QuantizedVectors* vectors);
  size_t size() const;
  int neighbors() const { return neighbors_; }
  const QuantizedVectors* vectors() const;

  /// Up to `k` (row, inner product) pairs, best first. `query`: a row built by
  /// QuantizedVectors::encode.
  std::vector<std::pair<size_t, float>> search(const uint8_t* query, size_t k, int ef_search) const;

  /// Writes the graph to `path` (hnswlib's layout) atomically: into `path`.tmp, then renamed.
  /// Throws std::runtime_error naming the path.
  void save(const std::string& path) const;
  /// Reads a graph written by save() over the first rows of `vectors`. Throws std::runtime_error
  /// when the file is not such a graph (other shape, more rows than `vectors` holds, a link
  /// outside them).
  static std::unique_ptr<ApproximateIndex> load(const std::string& path,
                                                const QuantizedVectors* vectors, int neighbors);

  /// Heap bytes of the links and the graph's bookkeeping (the vectors are counted by their owner).
  size_t bytes() const;
  /// What bytes() grows by per row on average with `neighbors` links (upper levels included as
  /// expected, capacity held ahead not).
  static size_t bytesPerRow(int neighbors);

 private:
  struct Graph;
  explicit ApproximateIndex(std::unique_ptr<Graph> graph, int neighbors);
  void reserve(size_t rows);

  std::unique_ptr<Graph> graph_;
  int neighbors_;
};

}  // namespace landmark_loop_closure
