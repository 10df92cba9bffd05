#pragma once

#include <atomic>
#include <memory>
#include <thread>

#include "landmark_loop_closure/database/approximate_index.h"
#include "landmark_loop_closure/database/quantized_vectors.h"

namespace landmark_loop_closure {

/// A search graph built on a thread of its own over a snapshot of a database's first rows, so
/// that opening a large map without its saved graph (about 2 ms a keyframe) does not hold the
/// thread that opens it (a nodelet manager's, at start) or the detector's worker. Search is exact
/// meanwhile; the owner swaps the graph in once ready() (take(), rebind() to its own vectors,
/// KeyframeDatabase::setIndex, which links the rows added since).
class BackgroundGraph {
 public:
  /// Starts linking `rows` into `start` (a graph read from the map over their first rows), or into
  /// a new graph of `index`'s shape when `start` is null.
  BackgroundGraph(std::unique_ptr<QuantizedVectors> rows, std::unique_ptr<ApproximateIndex> start,
                  const IndexOptions& index);
  /// Stops the build (between two rows) and waits for its thread.
  ~BackgroundGraph();
  BackgroundGraph(const BackgroundGraph&) = delete;
  BackgroundGraph& operator=(const BackgroundGraph&) = delete;

  /// Every row is linked (or the build failed: take() then gives null).
  bool ready() const { return done_.load(); }
  /// Rows the graph is built over.
  size_t rows() const { return rows_->size(); }
  /// Waits for the build; the graph over the snapshot's rows (rebind() it before this object
  /// goes, which frees them), or null when it failed (out of memory).
  std::unique_ptr<ApproximateIndex> take();

 private:
  void build();

  std::unique_ptr<QuantizedVectors> rows_;
  std::unique_ptr<ApproximateIndex> graph_;
  IndexOptions index_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> done_{false};
  std::thread thread_;
};

}  // namespace landmark_loop_closure
