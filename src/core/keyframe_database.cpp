#include "landmark_loop_closure/keyframe_database.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace landmark_loop_closure {

std::string DatabaseOptions::validate() const {
  std::ostringstream errors;
  if (exclude_recent_keyframes < 0) {
    errors << "database/exclude_recent_keyframes must be >= 0 (got " << exclude_recent_keyframes
           << ")\n";
  }
  if (!(exclude_recent_seconds >= 0.0)) {
    errors << "database/exclude_recent_seconds must be >= 0 (got " << exclude_recent_seconds
           << ")\n";
  }
  if (min_size < 1) errors << "database/min_size must be >= 1 (got " << min_size << ")\n";
  if (top_k < 1) errors << "database/top_k must be >= 1 (got " << top_k << ")\n";
  return errors.str();
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

KeyframeDatabase::KeyframeDatabase(int global_dimension) : global_dimension_(global_dimension) {
  if (global_dimension <= 0) throw std::invalid_argument("global descriptor dimension must be > 0");
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
  keyframes_.push_back(std::move(keyframe));
}

QueryResult KeyframeDatabase::query(const std::vector<float>& global, double stamp,
                                    const DatabaseOptions& options, uint32_t session) const {
  QueryResult result;
  if (keyframes_.size() < static_cast<size_t>(options.min_size)) {
    result.status = QueryStatus::kDatabaseTooSmall;
    return result;
  }
  size_t end = keyframes_.size();
  const size_t limit = static_cast<size_t>(options.exclude_recent_keyframes);
  while (end > 0 && keyframes_.size() - end < limit && keyframes_[end - 1].session == session) {
    --end;
  }
  std::vector<Candidate> scored;
  scored.reserve(end);
  for (size_t index = 0; index < end; ++index) {
    const KeyframeRecord& keyframe = keyframes_[index];
    if (std::abs(stamp - keyframe.stamp) < options.exclude_recent_seconds) continue;
    scored.push_back({index, keyframe.id, cosineSimilarity(global, keyframe.descriptor.global)});
  }
  result.searched = scored.size();
  if (scored.empty()) {
    result.status = QueryStatus::kAllExcluded;
    return result;
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
  size_t total = keyframes_.capacity() * sizeof(KeyframeRecord);
  for (const KeyframeRecord& keyframe : keyframes_) {
    total += keyframe.descriptor.bytes() + keyframe.local_features.bytes() +
             keyframe.thumbnail.total() * keyframe.thumbnail.elemSize();
  }
  return total;
}

}  // namespace landmark_loop_closure
