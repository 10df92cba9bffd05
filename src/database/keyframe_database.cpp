#include "landmark_loop_closure/database/keyframe_database.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "landmark_loop_closure/common/image_helpers.h"

namespace landmark_loop_closure {

const ParameterTable<DatabaseOptions>& DatabaseOptions::parameters() {
  using O = DatabaseOptions;
  static const auto table =
      ParameterTable<O>("advanced/database/", "database search.")
          .integer("exclude_recent_keyframes", &O::exclude_recent_keyframes, between(0, 1000000),
                   "the newest N keyframes are never loop candidates.")
          .number("exclude_recent_seconds", &O::exclude_recent_seconds, atLeast(0),
                  "nor are keyframes less than this many seconds older than the query.")
          .integer("min_size", &O::min_size, between(1, 1000000),
                   "no search until the database holds this many keyframes.")
          .integer("top_k", &O::top_k, between(1, 1000),
                   "candidates kept per query (landmarks re-rank them all).")
          .number("memory_budget_mb", &O::memory_budget_mb, atLeast(0),
                  "0: no limit. RAM of the keyframes (diagnostics \"database bytes\"): with a "
                  "map file (database_path) search keeps ~4.7 KB per keyframe shipped and reads "
                  "the rest from the file; without one every keyframe stays in RAM (~40 KB). It "
                  "bounds search, not the map: past it keyframes are still searched for loops "
                  "and written to the map file, not searched; a start searches the map's first "
                  "keyframes that fit it (or all its saved search graph covers, when more: "
                  "delete PATH-graph to build one within it) and leaves the rest on disk. "
                  "Without a map file they are no longer stored. A warning says so.")
          .group(&O::index, IndexOptions::parameters());
  return table;
}

std::string DatabaseOptions::validate() const {
  return parameters().check(*this) + index.validate();
}

const char* toString(QueryStatus status) {
  switch (status) {
    case QueryStatus::kSearched:
      return "searched";
    case QueryStatus::kDatabaseTooSmall:
      return "database_too_small";
    case QueryStatus::kAllExcluded:
      return "all_excluded";
    case QueryStatus::kMapDamaged:
      return "map_damaged";
  }
  return "unknown";
}

std::vector<uint8_t> encodeThumbnail(const cv::Mat& grey) {
  std::vector<uint8_t> bytes;
  // Quality 30: 1.8 KB against 2.6 KB at 60 on Gardens Point (PSNR 31.9 against 35.2 dB; side by
  // side at twice the size no difference shows), and a million-keyframe map is 0.8 GB smaller.
  if (!grey.empty()) cv::imencode(".webp", grey, bytes, {cv::IMWRITE_WEBP_QUALITY, 30});
  return bytes;
}

std::vector<uint8_t> makeThumbnail(const cv::Mat& image) {
  if (image.empty()) return {};
  return encodeThumbnail(toWorkingImage(image, 160, 120));
}

cv::Mat decodeThumbnail(const std::vector<uint8_t>& bytes) {
  if (bytes.empty()) return {};
  try {
    return cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception&) {
    return {};
  }
}

namespace {

// More excluded keyframes than this and the graph would have to return most of its neighbours
// only to drop them: exact search is then the cheaper and surer way.
constexpr size_t kMaxExcludedForGraph = 2000;

}  // namespace

size_t recordBytes(const KeyframeRecord& keyframe) {
  return sizeof(KeyframeRecord) + keyframe.descriptor.bytes() + keyframe.local_features.bytes() +
         keyframe.thumbnail.capacity();
}

KeyframeDatabase::KeyframeDatabase(int global_dimension, IndexOptions index) {
  if (global_dimension <= 0) throw std::invalid_argument("global descriptor dimension must be > 0");
  vectors_ = std::make_unique<QuantizedVectors>(global_dimension);
  setIndex(index);
}

KeyframeDatabase::KeyframeDatabase(KeyframeDatabase&&) noexcept = default;
KeyframeDatabase& KeyframeDatabase::operator=(KeyframeDatabase&&) noexcept = default;
KeyframeDatabase::~KeyframeDatabase() = default;

void KeyframeDatabase::setIndex(const IndexOptions& index,
                                std::unique_ptr<ApproximateIndex> graph) {
  const std::string problems = index.validate();
  if (!problems.empty()) throw std::invalid_argument(problems);
  if (graph && graph->vectors() != vectors_.get()) {
    throw std::invalid_argument("the graph is not over this database's vectors");
  }
  if (graph && graph->size() > size()) {
    throw std::invalid_argument("the graph holds " + std::to_string(graph->size()) +
                                " vectors, the database " + std::to_string(size()) + " keyframes");
  }
  index_options_ = index;
  // The projection only where a search may read it: kept while the options want it, else
  // dropped; a map opened past coarse_from learns it now.
  if (!wantsProjection()) {
    projection_.reset();
  } else {
    learnProjectionOnceDue(size());
  }
  if (!index.buildsGraph()) {
    graph_.reset();
    return;
  }
  if (!graph) {
    graph =
        std::make_unique<ApproximateIndex>(vectors_.get(), index.neighbors, index.ef_construction);
  }
  while (graph->size() < size()) graph->add();
  graph_ = std::move(graph);
}

void KeyframeDatabase::learnProjectionOnceDue(size_t rows) {
  if (!projection_ && rows >= static_cast<size_t>(index_options_.coarse_from)) {
    projection_ = std::make_unique<RowProjection>(*vectors_, index_options_.coarse_from);
  }
}

void KeyframeDatabase::addEntry(const KeyframeSummary& summary) {
  // Past approximate_from the graph searches; a map that grows there stops being projected. The
  // map that reaches coarse_from learns the projection from its rows, this one's included.
  if (projection_ && projection_->size() == size() &&
      size() < static_cast<size_t>(index_options_.approximate_from)) {
    projection_->append(vectors_->row(size()));
  } else if (wantsProjection()) {
    learnProjectionOnceDue(size() + 1);
  }
  summaries_.push_back(summary);
  stamps_.push_back(summary.stamp);
  if (graph_) graph_->add();
}

void KeyframeDatabase::add(KeyframeRecord keyframe) { add(std::move(keyframe), false); }

void KeyframeDatabase::addUnstored(KeyframeRecord keyframe) { add(std::move(keyframe), true); }

void KeyframeDatabase::add(KeyframeRecord keyframe, bool unstored) {
  if (!summaries_.empty() && keyframe.id <= summaries_.back().id) {
    throw std::invalid_argument("keyframe id " + std::to_string(keyframe.id) +
                                " is not greater than the last stored id " +
                                std::to_string(summaries_.back().id));
  }
  if (static_cast<int>(keyframe.descriptor.global.size()) != globalDimension()) {
    throw std::invalid_argument("global descriptor has " +
                                std::to_string(keyframe.descriptor.global.size()) +
                                " values, the database holds " + std::to_string(globalDimension()));
  }
  vectors_->append(keyframe.descriptor.global.data());
  // The record carries what search compares, so a record read back from the map file (which
  // keeps the 8-bit row) scores exactly as this one.
  keyframe.descriptor.global = QuantizedVectors::decode(vectors_->row(size()), globalDimension());
  addEntry(keyframe);
  auto record = std::make_shared<const KeyframeRecord>(std::move(keyframe));
  if (reader_ && unstored) {
    record_bytes_ += recordBytes(*record);
    unstored_.emplace(record->id, std::move(record));
  } else if (reader_) {
    cache(std::move(record));
  } else {
    record_bytes_ += recordBytes(*record);
    records_.push_back(std::move(record));
  }
}

void KeyframeDatabase::addSummary(const KeyframeSummary& summary, const uint8_t* vector_row,
                                  size_t row_bytes) {
  if (!summaries_.empty() && summary.id <= summaries_.back().id) {
    throw std::invalid_argument("keyframe id " + std::to_string(summary.id) +
                                " is not greater than the last stored id " +
                                std::to_string(summaries_.back().id));
  }
  vectors_->appendRow(vector_row, row_bytes);
  addEntry(summary);
  if (!reader_) records_.push_back(nullptr);
}

void KeyframeDatabase::addSaved(std::shared_ptr<const void> owner, const uint8_t* rows,
                                size_t count,
                                const std::function<KeyframeSummary(size_t)>& summary_of,
                                size_t stride) {
  if (!empty()) throw std::invalid_argument("saved rows go into an empty database only");
  std::vector<KeyframeSummary> summaries;
  summaries.reserve(count);
  for (size_t row = 0; row < count; ++row) {
    summaries.push_back(summary_of(row));
    if (row > 0 && summaries[row].id <= summaries[row - 1].id) {
      throw std::invalid_argument("saved keyframe id " + std::to_string(summaries[row].id) +
                                  " is not greater than the one before it");
    }
  }
  vectors_->adopt(std::move(owner), rows, count, stride);
  for (const KeyframeSummary& summary : summaries) {
    addEntry(summary);
    if (!reader_) records_.push_back(nullptr);
  }
}

void KeyframeDatabase::readRecordsFrom(RecordReader reader, size_t cached_records) {
  reader_ = std::move(reader);
  cached_records_ = std::max<size_t>(cached_records, 1);
  records_.clear();
  cache_.clear();
  cache_order_.clear();
  unstored_.clear();
  record_bytes_ = 0;
}

void KeyframeDatabase::cache(std::shared_ptr<const KeyframeRecord> record) const {
  const auto found = cache_.find(record->id);
  if (found != cache_.end()) {
    cache_order_.splice(cache_order_.end(), cache_order_, found->second);
    return;
  }
  record_bytes_ += recordBytes(*record);
  const uint64_t id = record->id;
  cache_order_.push_back(std::move(record));
  cache_[id] = std::prev(cache_order_.end());
  while (cache_order_.size() > cached_records_) {
    record_bytes_ -= recordBytes(*cache_order_.front());
    cache_.erase(cache_order_.front()->id);
    cache_order_.pop_front();
  }
}

std::shared_ptr<const KeyframeRecord> KeyframeDatabase::record(size_t index) const {
  const KeyframeSummary& summary = summaries_.at(index);
  if (!reader_) return records_.at(index);
  if (const auto kept = unstored_.find(summary.id); kept != unstored_.end()) return kept->second;
  const auto found = cache_.find(summary.id);
  if (found != cache_.end()) {
    std::shared_ptr<const KeyframeRecord> record = *found->second;
    cache(record);
    return record;
  }
  ++record_reads_;
  std::optional<KeyframeRecord> read = reader_(summary.id);
  if (!read) return nullptr;
  read->descriptor.global = QuantizedVectors::decode(vectors_->row(index), globalDimension());
  auto record = std::make_shared<const KeyframeRecord>(std::move(*read));
  cache(record);
  return record;
}

size_t KeyframeDatabase::searchEnd(const DatabaseOptions& options, uint32_t session) const {
  size_t end = summaries_.size();
  const size_t limit = static_cast<size_t>(options.exclude_recent_keyframes);
  while (end > 0 && summaries_.size() - end < limit && summaries_[end - 1].session == session) {
    --end;
  }
  return end;
}

bool KeyframeDatabase::eligible(size_t index, double stamp, const DatabaseOptions& options,
                                uint32_t session) const {
  return index < searchEnd(options, session) &&
         std::abs(stamp - stamps_[index]) >= options.exclude_recent_seconds;
}

double KeyframeDatabase::similarity(const std::vector<float>& global, size_t index) const {
  return similarity(encode(global), index);
}

KeyframeDatabase::EncodedQuery KeyframeDatabase::encode(const std::vector<float>& global) const {
  if (static_cast<int>(global.size()) != globalDimension()) {
    throw std::invalid_argument("query descriptor has " + std::to_string(global.size()) +
                                " values, the database holds " + std::to_string(globalDimension()));
  }
  return EncodedQuery{QuantizedVectors::encode(global)};
}

double KeyframeDatabase::similarity(const EncodedQuery& query, size_t index) const {
  return vectors_->dot(query.row.data(), index);
}

std::vector<double> KeyframeDatabase::similarities(const std::vector<float>& global,
                                                   const std::vector<size_t>& indices) const {
  if (static_cast<int>(global.size()) != globalDimension()) {
    throw std::invalid_argument("query descriptor has " + std::to_string(global.size()) +
                                " values, the database holds " + std::to_string(globalDimension()));
  }
  const auto encoded = QuantizedVectors::encode(global);
  std::vector<double> result;
  result.reserve(indices.size());
  for (const size_t index : indices) result.push_back(vectors_->dot(encoded.data(), index));
  return result;
}

std::optional<RowProjection::Projected> KeyframeDatabase::coarseProjection(
    const IndexOptions& index, const std::vector<uint8_t>& row, size_t end, size_t searched) const {
  if (index.type != "auto" || index.coarse_from <= 0 ||
      end < static_cast<size_t>(index.coarse_from) || !projection_ || projection_->size() < end ||
      searched <= static_cast<size_t>(index.coarse_candidates)) {
    return std::nullopt;
  }
  return projection_->project(row.data());
}

QueryResult KeyframeDatabase::query(const std::vector<float>& global, double stamp,
                                    const DatabaseOptions& options, uint32_t session) const {
  QueryResult result;
  if (size() < static_cast<size_t>(options.min_size)) {
    result.status = QueryStatus::kDatabaseTooSmall;
    return result;
  }
  if (static_cast<int>(global.size()) != globalDimension()) {
    throw std::invalid_argument("query descriptor has " + std::to_string(global.size()) +
                                " values, the database holds " + std::to_string(globalDimension()));
  }
  const std::vector<uint8_t> row = QuantizedVectors::encode(global);
  const size_t end = searchEnd(options, session);
  const auto outside_time_window = [&](size_t index) {
    return std::abs(stamp - stamps_[index]) >= options.exclude_recent_seconds;
  };
  for (size_t index = 0; index < end; ++index) result.searched += outside_time_window(index);
  if (result.searched == 0) {
    result.status = QueryStatus::kAllExcluded;
    return result;
  }
  const IndexOptions& index = options.index;
  const bool use_graph =
      graph_ && index.type != "exact" &&
      (index.type == "approximate" || size() >= static_cast<size_t>(index.approximate_from));
  // Ids are looked up once the candidates are kept (below): a summary is a cache line of its own.
  std::vector<Candidate> scored;
  const auto score_every_row = [&](const auto& score) {
    scored.reserve(result.searched);
    for (size_t index = 0; index < end; ++index) {
      if (outside_time_window(index)) scored.push_back({index, 0, score(index)});
    }
  };
  const size_t excluded = size() - result.searched;
  if (use_graph && excluded <= kMaxExcludedForGraph) {
    result.approximate = true;
    const size_t wanted = static_cast<size_t>(options.top_k) + excluded;
    for (const auto& [index, score] : graph_->search(row.data(), wanted, index.ef_search)) {
      if (index < end && outside_time_window(index)) {
        scored.push_back({index, 0, static_cast<double>(score)});
      }
    }
  } else if (const std::optional<RowProjection::Projected> projected =
                 coarseProjection(index, row, end, result.searched)) {
    // The projections rank every row, the best coarse_candidates are scored exactly, and with
    // them every row the directions do not describe (ranked first here).
    result.approximate = true;
    score_every_row([&](size_t index) {
      return projection_->describes(index) ? projection_->dot(*projected, index) : HUGE_VALF;
    });
    const size_t pool = std::min(
        scored.size(), static_cast<size_t>(index.coarse_candidates) + projection_->undescribed());
    const auto coarse_end = scored.begin() + static_cast<std::ptrdiff_t>(pool);
    std::nth_element(
        scored.begin(), coarse_end, scored.end(),
        [](const Candidate& a, const Candidate& b) { return a.global_score > b.global_score; });
    scored.erase(coarse_end, scored.end());
    for (Candidate& candidate : scored) {
      candidate.global_score = vectors_->dot(row.data(), candidate.index);
    }
  } else {
    score_every_row([&](size_t index) { return vectors_->dot(row.data(), index); });
  }
  const size_t keep = std::min(scored.size(), static_cast<size_t>(options.top_k));
  // Equal scores (a vehicle standing still stores the same image again) rank the older keyframe
  // first, however the candidates were found.
  std::partial_sort(scored.begin(), scored.begin() + static_cast<std::ptrdiff_t>(keep),
                    scored.end(), [](const Candidate& a, const Candidate& b) {
                      return a.global_score > b.global_score ||
                             (a.global_score == b.global_score && a.index < b.index);
                    });
  scored.resize(keep);
  for (Candidate& candidate : scored) candidate.id = summaries_[candidate.index].id;
  result.candidates = std::move(scored);
  result.status = QueryStatus::kSearched;
  return result;
}

std::optional<size_t> KeyframeDatabase::indexOf(uint64_t id) const {
  const auto it =
      std::lower_bound(summaries_.begin(), summaries_.end(), id,
                       [](const KeyframeSummary& k, uint64_t value) { return k.id < value; });
  if (it == summaries_.end() || it->id != id) return std::nullopt;
  return static_cast<size_t>(it - summaries_.begin());
}

const KeyframeSummary* KeyframeDatabase::findSummary(uint64_t id) const {
  const std::optional<size_t> index = indexOf(id);
  return index ? &summaries_[*index] : nullptr;
}

std::shared_ptr<const KeyframeRecord> KeyframeDatabase::findRecord(uint64_t id) const {
  const std::optional<size_t> index = indexOf(id);
  return index ? record(*index) : nullptr;
}

size_t KeyframeDatabase::bytesPerKeyframe(size_t row_stride) const {
  return sizeof(KeyframeSummary) + sizeof(double) +
         (row_stride > 0 ? row_stride : vectors_->rowBytes()) +
         (projection_ ? 2 * sizeof(float) + RowProjection::kDimension : 0) +
         (index_options_.buildsGraph() ? ApproximateIndex::bytesPerRow(index_options_.neighbors)
                                       : 0);
}

size_t KeyframeDatabase::bytes() const {
  return summaries_.size() * sizeof(KeyframeSummary) + stamps_.capacity() * sizeof(double) +
         records_.size() * sizeof(records_.front()) + vectors_->bytes() + record_bytes_ +
         (projection_ ? projection_->bytes() : 0) + (graph_ ? graph_->bytes() : 0);
}

}  // namespace landmark_loop_closure
