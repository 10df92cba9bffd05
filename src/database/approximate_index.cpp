#include "landmark_loop_closure/database/approximate_index.h"

#include "landmark_loop_closure/common/durable_file.h"

#include <hnswlib/hnswlib.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <new>
#include <sstream>
#include <stdexcept>

namespace landmark_loop_closure {

std::string IndexOptions::graphIdentity() const {
  std::ostringstream identity;
  identity << "hnsw_int8_rows M=" << neighbors << " efC=" << ef_construction;
  return identity.str();
}

const ParameterTable<IndexOptions>& IndexOptions::parameters() {
  using O = IndexOptions;
  static const auto table =
      ParameterTable<O>(
          "advanced/database/index/",
          "how global descriptors are searched: 8 bits per value (a scale per "
          "keyframe), exactly or through an HNSW graph (bench/history.md, \"Map at "
          "scale\"). The graph is saved beside the map file (PATH-graph) at shutdown; "
          "changing neighbors or ef_construction rebuilds it at start (~2 ms per "
          "keyframe).")
          .word("type", &O::type, {"exact", "approximate", "auto"},
                "\"exact\": compare every keyframe; \"approximate\": an HNSW graph (hnswlib) gives "
                "the shortlist; \"auto\": the graph is kept from the start, used once "
                "approximate_from keyframes are stored.")
          .integer("approximate_from", &O::approximate_from, between(1, 100000000),
                   "auto: exact search below this size (~8 ms at 20 000).")
          .integer("neighbors", &O::neighbors, between(4, 128),
                   "HNSW links per keyframe (M): recall and memory grow with it.")
          .evaluationOnly()
          .integer("ef_construction", &O::ef_construction, between(4, 4096),
                   "HNSW insertion effort: graph quality against insert time; >= neighbors. "
                   "128: recall@10 1.000 at 100 000 keyframes (64: 0.99), insert 2.3 ms "
                   "median (64: 0.85 ms) on the worker thread (lcd_bench_map).")
          .evaluationOnly()
          .integer("ef_search", &O::ef_search, between(1, 4096),
                   "HNSW search effort: shortlist recall against query time.")
          .integer("coarse_from", &O::coarse_from, between(0, 100000000),
                   "with type auto, below approximate_from, a map of at least this many "
                   "keyframes is searched through each row projected onto 256 directions "
                   "learned from the map's first coarse_from rows (once, about 1 s on the "
                   "worker), the coarse_candidates best scored exactly, and with them every row "
                   "the directions describe worse than 99 % of the learned ones: 1.2 against 6.6 "
                   "ms at 10 000 keyframes; the shortlist's recall@10 against exact search 0.995 "
                   "there, 1.000 with every keyframe a view of its own (lcd_bench_pipeline "
                   "--distinct), 0.9999 on Nordland. 0: every keyframe scored exactly.")
          .integer("coarse_candidates", &O::coarse_candidates, between(1, 100000),
                   "keyframes the projections pass on to be scored exactly.")
          .evaluationOnly();
  return table;
}

std::string IndexOptions::validate() const {
  std::string errors = parameters().check(*this);
  if (ef_construction < neighbors) {
    errors += "advanced/database/index/ef_construction (" + std::to_string(ef_construction) +
              ") must be >= advanced/database/index/neighbors (" + std::to_string(neighbors) +
              ")\n";
  }
  return errors;
}

namespace {

// What the graph stores per element: the row number. The query is not a row, so it is passed as
// this number and read from the space's context.
using Row = uint32_t;
constexpr Row kQueryRow = std::numeric_limits<Row>::max();

class RowSpace : public hnswlib::SpaceInterface<float> {
 public:
  struct Context {
    const QuantizedVectors* vectors = nullptr;
    const uint8_t* query = nullptr;
  };

  explicit RowSpace(const QuantizedVectors* vectors) { context_.vectors = vectors; }
  size_t get_data_size() override { return sizeof(Row); }
  hnswlib::DISTFUNC<float> get_dist_func() override { return &distance; }
  void* get_dist_func_param() override { return &context_; }
  void setQuery(const uint8_t* query) { context_.query = query; }
  void setVectors(const QuantizedVectors* vectors) { context_.vectors = vectors; }

 private:
  static const uint8_t* rowOf(const void* data, const Context& context) {
    Row row;
    std::memcpy(&row, data, sizeof(Row));
    return row == kQueryRow ? context.query : context.vectors->row(row);
  }
  static float distance(const void* a, const void* b, const void* param) {
    const auto& context = *static_cast<const Context*>(param);
    return 1.0f - QuantizedVectors::dot(rowOf(a, context), rowOf(b, context),
                                        context.vectors->dimension());
  }

  Context context_;
};

using Hnsw = hnswlib::HierarchicalNSW<float>;

// Bytes hnswlib's saveIndex writes: its header fields, the base layer, then each element's
// upper-level links with their length. Checked after writing, since saveIndex reports no error.
size_t savedBytes(const Hnsw& hnsw) {
  size_t bytes = sizeof(hnsw.offsetLevel0_) + sizeof(hnsw.max_elements_) +
                 sizeof(hnsw.cur_element_count) + sizeof(hnsw.size_data_per_element_) +
                 sizeof(hnsw.label_offset_) + sizeof(hnsw.offsetData_) + sizeof(hnsw.maxlevel_) +
                 sizeof(hnsw.enterpoint_node_) + sizeof(hnsw.maxM_) + sizeof(hnsw.maxM0_) +
                 sizeof(hnsw.M_) + sizeof(hnsw.mult_) + sizeof(hnsw.ef_construction_);
  bytes += hnsw.cur_element_count * hnsw.size_data_per_element_;
  for (size_t i = 0; i < hnsw.cur_element_count; ++i) {
    bytes += sizeof(unsigned int) + static_cast<size_t>(std::max(0, hnsw.element_levels_[i])) *
                                        hnsw.size_links_per_element_;
  }
  return bytes;
}

// hnswlib 0.6.2's search prefetches the link after a list's last, so a full list of an upper level
// (allocated to its exact size, one element at a time) is read past its end. Each element's upper
// lists get room for that link, zeroed (the prefetch then names element 0).
void padUpperLinks(Hnsw& hnsw, size_t element) {
  const int levels = hnsw.element_levels_[element];
  if (levels <= 0) return;
  const size_t bytes = hnsw.size_links_per_element_ * static_cast<size_t>(levels) + 1;
  char* padded =
      static_cast<char*>(std::realloc(hnsw.linkLists_[element], bytes + sizeof(hnswlib::tableint)));
  if (padded == nullptr) throw std::bad_alloc();
  std::memset(padded + bytes, 0, sizeof(hnswlib::tableint));
  hnsw.linkLists_[element] = padded;
}

size_t upperLinkBytes(const Hnsw& hnsw, size_t element) {
  return static_cast<size_t>(std::max(0, hnsw.element_levels_[element])) *
         hnsw.size_links_per_element_;
}

// Every element holds its own row and links only to elements of the graph: a graph read from a
// file is never searched through a link that leads outside it.
bool linksStayInside(const Hnsw& hnsw) {
  const size_t count = hnsw.cur_element_count;
  const auto inside = [&](const unsigned int* list, size_t capacity) {
    const size_t links = hnsw.getListCount(const_cast<unsigned int*>(list));
    if (links > capacity) return false;
    const auto* ids = reinterpret_cast<const hnswlib::tableint*>(list + 1);
    for (size_t i = 0; i < links; ++i) {
      if (ids[i] >= count) return false;
    }
    return true;
  };
  for (size_t element = 0; element < count; ++element) {
    const auto id = static_cast<hnswlib::tableint>(element);
    Row row;
    std::memcpy(&row, hnsw.getDataByInternalId(id), sizeof(Row));
    if (row != element || hnsw.getExternalLabel(id) != element) return false;
    if (!inside(hnsw.get_linklist0(id), hnsw.maxM0_)) return false;
    for (int level = 1; level <= hnsw.element_levels_[element]; ++level) {
      if (!inside(hnsw.get_linklist(id, level), hnsw.maxM_)) return false;
    }
  }
  return count == 0 || static_cast<size_t>(hnsw.enterpoint_node_) < count;
}

}  // namespace

struct ApproximateIndex::Graph {
  explicit Graph(const QuantizedVectors* vectors) : space(vectors), vectors(vectors) {}
  RowSpace space;
  const QuantizedVectors* vectors;
  std::unique_ptr<Hnsw> hnsw;
  size_t upper_link_bytes = 0;  ///< Links above the base layer, allocated one element at a time.
};

ApproximateIndex::ApproximateIndex(std::unique_ptr<Graph> graph, int neighbors)
    : graph_(std::move(graph)), neighbors_(neighbors) {}

ApproximateIndex::ApproximateIndex(const QuantizedVectors* vectors, int neighbors,
                                   int ef_construction)
    : graph_(std::make_unique<Graph>(vectors)), neighbors_(neighbors) {
  if (vectors == nullptr) throw std::invalid_argument("an index needs its vectors");
  if (neighbors < 2) throw std::invalid_argument("an index needs at least 2 neighbours");
  constexpr size_t kFirstCapacity = 1024;
  graph_->hnsw =
      std::make_unique<Hnsw>(&graph_->space, kFirstCapacity, static_cast<size_t>(neighbors),
                             static_cast<size_t>(ef_construction));
}

ApproximateIndex::~ApproximateIndex() = default;

void ApproximateIndex::reserve(size_t rows) {
  Hnsw& hnsw = *graph_->hnsw;
  if (rows <= hnsw.max_elements_) return;
  hnsw.resizeIndex(std::max(rows, 2 * hnsw.max_elements_));
}

void ApproximateIndex::add() {
  const size_t row = size();
  if (row >= graph_->vectors->size()) {
    throw std::logic_error("the graph has no vector row " + std::to_string(row) + " to add");
  }
  reserve(row + 1);
  const auto data = static_cast<Row>(row);
  graph_->hnsw->addPoint(&data, row);
  padUpperLinks(*graph_->hnsw, row);
  graph_->upper_link_bytes += upperLinkBytes(*graph_->hnsw, row);
}

size_t ApproximateIndex::size() const { return graph_->hnsw->cur_element_count; }

const QuantizedVectors* ApproximateIndex::vectors() const { return graph_->vectors; }

void ApproximateIndex::rebind(const QuantizedVectors* vectors) {
  if (vectors == nullptr || vectors->size() < size()) {
    throw std::invalid_argument("a graph rebound to vectors without its rows");
  }
  graph_->vectors = vectors;
  graph_->space.setVectors(vectors);
}

std::vector<std::pair<size_t, float>> ApproximateIndex::search(const uint8_t* query, size_t k,
                                                               int ef_search) const {
  std::vector<std::pair<size_t, float>> found;
  if (k == 0 || size() == 0) return found;
  graph_->space.setQuery(query);
  graph_->hnsw->setEf(std::max(static_cast<size_t>(std::max(ef_search, 1)), k));
  auto best = graph_->hnsw->searchKnn(&kQueryRow, k);
  graph_->space.setQuery(nullptr);
  found.resize(best.size());
  for (size_t i = found.size(); i-- > 0; best.pop()) {  // The queue gives the worst first.
    found[i] = {best.top().second, 1.0f - best.top().first};
  }
  return found;
}

void ApproximateIndex::save(const std::string& path) const {
  const std::string temporary = path + ".tmp";
  std::error_code error;
  try {
    graph_->hnsw->saveIndex(temporary);
  } catch (const std::exception& failure) {
    std::filesystem::remove(temporary, error);
    throw std::runtime_error("search graph " + path + ": " + failure.what());
  }
  const uintmax_t written = std::filesystem::file_size(temporary, error);
  if (error || written != savedBytes(*graph_->hnsw)) {
    std::filesystem::remove(temporary, error);
    throw std::runtime_error("search graph " + path + ": could not be written (disk full?)");
  }
  if (const std::string failed = syncAndRename(temporary, path); !failed.empty()) {
    throw std::runtime_error("search graph " + path + ": " + failed);
  }
}

std::unique_ptr<ApproximateIndex> ApproximateIndex::load(const std::string& path,
                                                         const QuantizedVectors* vectors,
                                                         int neighbors) {
  auto graph = std::make_unique<Graph>(vectors);
  graph->hnsw = std::make_unique<Hnsw>(&graph->space);
  const auto refuse = [&](const std::string& why) {
    return std::runtime_error("search graph " + path + ": " + why);
  };
  try {
    graph->hnsw->loadIndex(path, &graph->space, std::max<size_t>(vectors->size(), 1));
  } catch (const std::exception& error) {
    throw refuse(error.what());
  }
  const Hnsw& hnsw = *graph->hnsw;
  if (hnsw.maxM0_ != 2 * static_cast<size_t>(neighbors) || hnsw.data_size_ != sizeof(Row) ||
      hnsw.cur_element_count > vectors->size()) {
    throw refuse("another shape, or more rows than the map holds");
  }
  if (!linksStayInside(hnsw)) throw refuse("damaged (a link leads outside the graph)");
  for (size_t i = 0; i < hnsw.cur_element_count; ++i) {
    padUpperLinks(*graph->hnsw, i);
    graph->upper_link_bytes += upperLinkBytes(hnsw, i);
  }
  return std::unique_ptr<ApproximateIndex>(new ApproximateIndex(std::move(graph), neighbors));
}

size_t ApproximateIndex::bytesPerRow(int neighbors) {
  const auto m = static_cast<size_t>(std::max(2, neighbors));
  const size_t links = sizeof(hnswlib::linklistsizeint);
  const size_t base = 2 * m * sizeof(hnswlib::tableint) + links + sizeof(Row) +
                      sizeof(hnswlib::labeltype) + sizeof(std::mutex) + sizeof(int) +
                      sizeof(void*) + sizeof(hnswlib::vl_type);
  const size_t label = sizeof(std::pair<const size_t, hnswlib::tableint>) + 3 * sizeof(void*);
  // A row reaches level l with probability m^-l: 1 / (m - 1) upper levels expected.
  const size_t upper = (m * sizeof(hnswlib::tableint) + links) / (m - 1);
  return base + label + upper;
}

size_t ApproximateIndex::bytes() const {
  const Hnsw& hnsw = *graph_->hnsw;
  const size_t per_capacity = hnsw.size_data_per_element_ + sizeof(std::mutex) + sizeof(int) +
                              sizeof(void*) + sizeof(hnswlib::vl_type);
  // label_lookup_: an unordered_map node and bucket per element.
  const size_t per_element = sizeof(std::pair<const size_t, hnswlib::tableint>) + 3 * sizeof(void*);
  return hnsw.max_elements_ * per_capacity + hnsw.cur_element_count * per_element +
         graph_->upper_link_bytes;
}

}  // namespace landmark_loop_closure
