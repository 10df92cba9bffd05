#include "landmark_loop_closure/database/background_graph.h"

#include <exception>

namespace landmark_loop_closure {

BackgroundGraph::BackgroundGraph(std::unique_ptr<QuantizedVectors> rows,
                                 std::unique_ptr<ApproximateIndex> start, const IndexOptions& index)
    : rows_(std::move(rows)), graph_(std::move(start)), index_(index) {
  if (graph_) graph_->rebind(rows_.get());
  thread_ = std::thread([this] { build(); });
}

BackgroundGraph::~BackgroundGraph() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void BackgroundGraph::build() {
  try {
    if (!graph_) {
      graph_ =
          std::make_unique<ApproximateIndex>(rows_.get(), index_.neighbors, index_.ef_construction);
    }
    while (graph_->size() < rows_->size() && !stop_.load()) graph_->add();
  } catch (const std::exception&) {
    graph_.reset();  // Out of memory: search stays exact.
  }
  done_ = true;
}

std::unique_ptr<ApproximateIndex> BackgroundGraph::take() {
  if (thread_.joinable()) thread_.join();
  if (graph_ && graph_->size() < rows_->size()) graph_.reset();  // Stopped before the end.
  return std::move(graph_);
}

}  // namespace landmark_loop_closure
