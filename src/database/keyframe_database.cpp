#include "landmark_loop_closure/database/keyframe_database.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

namespace landmark_loop_closure {

const ParameterTable<DatabaseOptions>& DatabaseOptions::parameters() {
  using O = DatabaseOptions;
  static const auto table =
      ParameterTable<O>("database/", "database search.")
          .integer("exclude_recent_keyframes", &O::exclude_recent_keyframes, atLeast(0),
                   "the newest N keyframes are never loop candidates.")
          .number("exclude_recent_seconds", &O::exclude_recent_seconds, atLeast(0),
                  "nor are keyframes less than this many seconds older than the query.")
          .integer("min_size", &O::min_size, atLeast(1),
                   "no search until the database holds this many keyframes.")
          .integer("top_k", &O::top_k, atLeast(1),
                   "candidates kept per query (landmarks re-rank them all).")
          .number("memory_budget_mb", &O::memory_budget_mb, atLeast(0),
                  "0: no limit. Past this many MB (diagnostics \"database bytes\", ~53 KB per "
                  "keyframe shipped) keyframes are still searched for loops but no longer stored; "
                  "a warning says so.")
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
  }
  return "unknown";
}

std::vector<uint8_t> encodeThumbnail(const cv::Mat& grey) {
  std::vector<uint8_t> jpeg;
  if (!grey.empty()) cv::imencode(".jpg", grey, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90});
  return jpeg;
}

cv::Mat decodeThumbnail(const std::vector<uint8_t>& jpeg) {
  if (jpeg.empty()) return {};
  try {
    return cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception&) {
    return {};
  }
}

namespace {

// More excluded keyframes than this and the graph would have to return most of its neighbours
// only to drop them: exact search is then the cheaper and surer way.
constexpr size_t kMaxExcludedForGraph = 2000;

}  // namespace

KeyframeDatabase::KeyframeDatabase(int global_dimension, IndexOptions index)
    : global_dimension_(global_dimension) {
  if (global_dimension <= 0) throw std::invalid_argument("global descriptor dimension must be > 0");
  setIndex(index);
}

KeyframeDatabase::KeyframeDatabase(KeyframeDatabase&&) noexcept = default;
KeyframeDatabase& KeyframeDatabase::operator=(KeyframeDatabase&&) noexcept = default;
KeyframeDatabase::~KeyframeDatabase() = default;

void KeyframeDatabase::setIndex(const IndexOptions& index,
                                std::unique_ptr<ApproximateIndex> graph) {
  const std::string problems = index.validate();
  if (!problems.empty()) throw std::invalid_argument(problems);
  if (graph && (graph->size() != keyframes_.size() || graph->dimension() != global_dimension_)) {
    throw std::invalid_argument("the graph holds " + std::to_string(graph->size()) +
                                " vectors, the database " + std::to_string(keyframes_.size()) +
                                " keyframes");
  }
  index_options_ = index;
  if (!index.buildsGraph()) {
    graph_.reset();
    return;
  }
  if (!graph) {
    graph = std::make_unique<ApproximateIndex>(global_dimension_, index.neighbors,
                                               index.ef_construction);
    for (const KeyframeRecord& keyframe : keyframes_) graph->add(keyframe.descriptor.global.data());
  }
  graph_ = std::move(graph);
}

void KeyframeDatabase::add(KeyframeRecord keyframe) {
  if (!keyframes_.empty() && keyframe.id <= keyframes_.back().id) {
    throw std::invalid_argument("keyframe id " + std::to_string(keyframe.id) +
                                " is not greater than the last stored id " +
                                std::to_string(keyframes_.back().id));
  }
  if (static_cast<int>(keyframe.descriptor.global.size()) != global_dimension_) {
    throw std::invalid_argument("global descriptor has " +
                                std::to_string(keyframe.descriptor.global.size()) +
                                " values, the database holds " + std::to_string(global_dimension_));
  }
  if (graph_) graph_->add(keyframe.descriptor.global.data());
  stamps_.push_back(keyframe.stamp);
  content_bytes_ += keyframe.descriptor.bytes() + keyframe.local_features.bytes() +
                    keyframe.thumbnail_jpeg.capacity();
  keyframes_.push_back(std::move(keyframe));
}

size_t KeyframeDatabase::searchEnd(const DatabaseOptions& options, uint32_t session) const {
  size_t end = keyframes_.size();
  const size_t limit = static_cast<size_t>(options.exclude_recent_keyframes);
  while (end > 0 && keyframes_.size() - end < limit && keyframes_[end - 1].session == session) {
    --end;
  }
  return end;
}

bool KeyframeDatabase::eligible(size_t index, double stamp, const DatabaseOptions& options,
                                uint32_t session) const {
  return index < searchEnd(options, session) &&
         std::abs(stamp - stamps_[index]) >= options.exclude_recent_seconds;
}

QueryResult KeyframeDatabase::query(const std::vector<float>& global, double stamp,
                                    const DatabaseOptions& options, uint32_t session) const {
  QueryResult result;
  if (keyframes_.size() < static_cast<size_t>(options.min_size)) {
    result.status = QueryStatus::kDatabaseTooSmall;
    return result;
  }
  if (static_cast<int>(global.size()) != global_dimension_) {
    throw std::invalid_argument("query descriptor has " + std::to_string(global.size()) +
                                " values, the database holds " + std::to_string(global_dimension_));
  }
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
  const bool use_graph = graph_ && index.type != "exact" &&
                         (index.type == "approximate" ||
                          keyframes_.size() >= static_cast<size_t>(index.approximate_from));
  std::vector<Candidate> scored;
  const size_t excluded = keyframes_.size() - result.searched;
  if (use_graph && excluded <= kMaxExcludedForGraph) {
    result.approximate = true;
    const size_t wanted = static_cast<size_t>(options.top_k) + excluded;
    for (const auto& [index, score] : graph_->search(global.data(), wanted, index.ef_search)) {
      if (index < end && outside_time_window(index)) {
        scored.push_back({index, keyframes_[index].id, static_cast<double>(score)});
      }
    }
  } else {
    scored.reserve(result.searched);
    for (size_t index = 0; index < end; ++index) {
      if (!outside_time_window(index)) continue;
      scored.push_back({index, keyframes_[index].id,
                        cosineSimilarity(global, keyframes_[index].descriptor.global)});
    }
  }
  const size_t keep = std::min(scored.size(), static_cast<size_t>(options.top_k));
  std::partial_sort(
      scored.begin(), scored.begin() + static_cast<std::ptrdiff_t>(keep), scored.end(),
      [](const Candidate& a, const Candidate& b) { return a.global_score > b.global_score; });
  scored.resize(keep);
  result.candidates = std::move(scored);
  result.status = QueryStatus::kSearched;
  return result;
}

const KeyframeRecord* KeyframeDatabase::findById(uint64_t id) const {
  const auto it =
      std::lower_bound(keyframes_.begin(), keyframes_.end(), id,
                       [](const KeyframeRecord& k, uint64_t value) { return k.id < value; });
  return it != keyframes_.end() && it->id == id ? &*it : nullptr;
}

size_t KeyframeDatabase::bytes() const {
  return keyframes_.size() * sizeof(KeyframeRecord) + stamps_.capacity() * sizeof(double) +
         content_bytes_ + (graph_ ? graph_->bytes() : 0);
}

}  // namespace landmark_loop_closure
