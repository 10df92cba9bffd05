#include "landmark_loop_closure/database/approximate_index.h"

#include <omp.h>

#include <faiss/IndexFlat.h>
#include <faiss/IndexHNSW.h>
#include <faiss/impl/FaissException.h>
#include <faiss/impl/io.h>
#include <faiss/index_io.h>

#include <sstream>
#include <stdexcept>

namespace landmark_loop_closure {

namespace {

// faiss parallelises with OpenMP; one vector at a time gains nothing from a thread team, and the
// node's other threads need the cores. The setting belongs to the calling thread.
void oneThread() { omp_set_num_threads(1); }

}  // namespace

std::string IndexOptions::graphIdentity() const {
  std::ostringstream identity;
  identity << "hnsw_flat_ip M=" << neighbors << " efC=" << ef_construction;
  return identity.str();
}

const ParameterTable<IndexOptions>& IndexOptions::parameters() {
  using O = IndexOptions;
  static const auto table =
      ParameterTable<O>("database/index/",
                        "how global descriptors are searched (bench/results/scaling.md). The graph "
                        "is saved with the database; changing neighbors or ef_construction "
                        "rebuilds it at load (~0.5 ms per keyframe).")
          .word("type", &O::type, {"exact", "approximate", "auto"},
                "\"exact\": compare every keyframe; \"approximate\": an HNSW graph (faiss) gives "
                "the shortlist; \"auto\": the graph is kept from the start, used once "
                "approximate_from keyframes are stored.")
          .integer("approximate_from", &O::approximate_from, atLeast(1),
                   "auto: exact search below this size (~8 ms at 20 000).")
          .integer("neighbors", &O::neighbors, between(4, 128),
                   "HNSW links per keyframe (M): recall and memory grow with it.")
          .integer("ef_construction", &O::ef_construction, atLeast(4),
                   "HNSW insertion effort: graph quality against insert time; >= neighbors.")
          .integer("ef_search", &O::ef_search, atLeast(1),
                   "HNSW search effort: shortlist recall against query time.");
  return table;
}

std::string IndexOptions::validate() const {
  std::string errors = parameters().check(*this);
  if (ef_construction < neighbors) {
    errors += "database/index/ef_construction (" + std::to_string(ef_construction) +
              ") must be >= database/index/neighbors (" + std::to_string(neighbors) + ")\n";
  }
  return errors;
}

struct ApproximateIndex::Graph {
  std::unique_ptr<faiss::IndexHNSW> index;
};

ApproximateIndex::ApproximateIndex(int dimension, std::unique_ptr<Graph> graph)
    : dimension_(dimension), graph_(std::move(graph)) {}

ApproximateIndex::ApproximateIndex(int dimension, int neighbors, int ef_construction)
    : dimension_(dimension), graph_(std::make_unique<Graph>()) {
  if (dimension <= 0) throw std::invalid_argument("index dimension must be > 0");
  graph_->index =
      std::make_unique<faiss::IndexHNSWFlat>(dimension, neighbors, faiss::METRIC_INNER_PRODUCT);
  graph_->index->hnsw.efConstruction = ef_construction;
}

ApproximateIndex::~ApproximateIndex() = default;

void ApproximateIndex::add(const float* vector) {
  oneThread();
  graph_->index->add(1, vector);
}

size_t ApproximateIndex::size() const { return static_cast<size_t>(graph_->index->ntotal); }

std::vector<std::pair<size_t, float>> ApproximateIndex::search(const float* query, size_t k,
                                                               int ef_search) const {
  std::vector<std::pair<size_t, float>> found;
  if (k == 0 || size() == 0) return found;
  oneThread();
  // faiss 1.7.3 reads the search effort from the index, not from SearchParametersHNSW.
  graph_->index->hnsw.efSearch = std::max(ef_search, static_cast<int>(k));
  std::vector<float> scores(k);
  std::vector<faiss::Index::idx_t> labels(k);
  graph_->index->search(1, query, static_cast<faiss::Index::idx_t>(k), scores.data(),
                        labels.data());
  for (size_t i = 0; i < k; ++i) {
    if (labels[i] >= 0) found.emplace_back(static_cast<size_t>(labels[i]), scores[i]);
  }
  return found;
}

std::vector<uint8_t> ApproximateIndex::toBytes() const {
  faiss::VectorIOWriter writer;
  faiss::write_index(graph_->index.get(), &writer);
  return std::move(writer.data);
}

std::unique_ptr<ApproximateIndex> ApproximateIndex::fromBytes(std::vector<uint8_t> bytes,
                                                              int dimension, int neighbors) {
  faiss::VectorIOReader reader;
  reader.data = std::move(bytes);
  std::unique_ptr<faiss::Index> index;
  try {
    index.reset(faiss::read_index(&reader));
  } catch (const faiss::FaissException& error) {
    throw std::runtime_error(std::string("not a readable HNSW index: ") + error.what());
  }
  auto* hnsw = dynamic_cast<faiss::IndexHNSWFlat*>(index.get());
  if (!hnsw || hnsw->metric_type != faiss::METRIC_INNER_PRODUCT || hnsw->d != dimension ||
      hnsw->hnsw.nb_neighbors(0) != 2 * neighbors) {
    throw std::runtime_error("the stored HNSW index has another type, metric, dimension or shape");
  }
  index.release();
  auto graph = std::make_unique<Graph>();
  graph->index.reset(hnsw);
  return std::unique_ptr<ApproximateIndex>(new ApproximateIndex(dimension, std::move(graph)));
}

size_t ApproximateIndex::bytes() const {
  const faiss::HNSW& hnsw = graph_->index->hnsw;
  return size() * static_cast<size_t>(dimension_) * sizeof(float) +
         hnsw.neighbors.capacity() * sizeof(faiss::HNSW::storage_idx_t) +
         hnsw.levels.capacity() * sizeof(int) + hnsw.offsets.capacity() * sizeof(size_t);
}

}  // namespace landmark_loop_closure
