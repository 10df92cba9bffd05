// Another robot's map: its rows kept in id order, and the querying run's path scores over them,
// exact on a small map, on its nearest rows and a fixed sample on a large one.
#include "landmark_loop_closure/fleet/foreign_map.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace landmark_loop_closure {

ForeignMap::ForeignMap(std::string robot, std::string peer, uint64_t ordinal, int dimension,
                       const ForeignSearchOptions& search)
    : robot_(std::move(robot)),
      peer_(std::move(peer)),
      ordinal_(ordinal),
      search_(search),
      vectors_(std::make_unique<QuantizedVectors>(dimension)) {
  // The graph grows with the map from its first row, so that a map reaching approximate_from is
  // searchable at once (no pause to build it).
  if (search_.approximate_from > 0) {
    graph_ = std::make_unique<ApproximateIndex>(vectors_.get(), search_.neighbors,
                                                search_.ef_construction);
  }
}

void ForeignMap::add(const SharedKeyframe& row) {
  ids_.insert(row.id);
  const size_t position = rows_.size();
  const auto later =
      std::upper_bound(by_id_.begin(), by_id_.end(), row.id,
                       [this](uint64_t id, size_t other) { return id < rows_[other].id; });
  const size_t inserted = static_cast<size_t>(later - by_id_.begin());
  by_id_.insert(later, position);
  rank_.push_back(inserted);
  // An earlier keyframe (a backlog): the later ones move up one place.
  for (size_t r = inserted + 1; r < by_id_.size(); ++r) rank_[by_id_[r]] = r;
  vectors_->appendRow(row.global_row.data(), row.global_row.size());
  if (graph_) graph_->add();
  SharedKeyframe kept = row;
  kept.global_row.clear();
  kept.global_row.shrink_to_fit();
  rows_.push_back(std::move(kept));
}

float ForeignMap::cosine(const QueryKeyframe& keyframe, size_t position) const {
  float& value = keyframe.cosines->values[position];
  if (std::isnan(value)) {
    value = vectors_->dot(keyframe.row, position);
    ++keyframe.cosines->computed;
  }
  return value;
}

void ForeignMap::scorePaths(const std::vector<QueryKeyframe>& run,
                            const std::vector<double>& speeds, const std::vector<size_t>& ranks,
                            const std::vector<bool>& sampled, MapScores* scores) const {
  const size_t slots = run.size();
  for (size_t i = 0; i < ranks.size(); ++i) {
    const size_t rank = ranks[i];
    double best = -HUGE_VAL;
    for (const double speed : speeds) {
      double sum = 0.0;
      bool complete = true;
      for (size_t slot = 0; slot < slots; ++slot) {
        const size_t step = static_cast<size_t>(std::lround(static_cast<double>(slot) * speed));
        if (step > rank) {
          complete = false;
          break;
        }
        sum += cosine(run[slot], by_id_[rank - step]);
      }
      if (complete) best = std::max(best, sum / static_cast<double>(slots));
      if (slots == 1) break;  // One keyframe: every speed reads the same cosine.
    }
    if (best > -HUGE_VAL) scores->rows.push_back({by_id_[rank], best, sampled[i]});
  }
}

MapScores ForeignMap::score(const std::vector<QueryKeyframe>& run,
                            const std::vector<double>& speeds) const {
  MapScores scores;
  const size_t rows = rows_.size();
  if (run.empty() || rows == 0) return scores;
  const bool approximate = graph_ && search_.approximate_from > 0 &&
                           rows >= static_cast<size_t>(search_.approximate_from);
  for (const QueryKeyframe& keyframe : run) {
    keyframe.cosines->values.resize(rows, std::numeric_limits<float>::quiet_NaN());
  }
  if (!approximate) {
    // Every row, by position: each keyframe's cosines to the rows that came since it last looked.
    for (const QueryKeyframe& keyframe : run) {
      for (size_t position = 0; position < rows; ++position) cosine(keyframe, position);
    }
    std::vector<size_t> ranks(rows);
    for (size_t position = 0; position < rows; ++position) ranks[position] = rank_[position];
    scorePaths(run, speeds, ranks, std::vector<bool>(rows, true), &scores);
    return scores;
  }
  scores.approximate = true;
  // The newest keyframe's nearest rows; the older ones' were found when each was newest.
  KeyframeCosines& newest = *run.front().cosines;
  if (!newest.searched) {
    for (const auto& [position, similarity] :
         graph_->search(run.front().row, static_cast<size_t>(search_.nearest), search_.ef_search)) {
      newest.nearest.push_back(position);
    }
    newest.searched = true;
  }
  // A path ending at a row passes near a keyframe's nearest row as many steps back as that
  // keyframe is old: the newest keyframe's nearest rows are paths' ends, and each older
  // keyframe's, moved forward as many ids as it is old (a path at one id a keyframe), are too
  // (where the newest keyframe alone is not near its place).
  std::vector<uint8_t> read(rows, 0);  // 1: a path's end near the run; 2: in the sample.
  for (size_t slot = 0; slot < run.size(); ++slot) {
    for (const size_t position : run[slot].cosines->nearest) {
      if (position >= rows) continue;
      const size_t end = rank_[position] + slot;
      if (end < rows) read[end] |= 1;
    }
  }
  // The sample: blocks of contiguous keyframes at a stride that doubles as the map grows, as the
  // detector samples its own map's background, so that one keyframe's cosines serve the next.
  const size_t blocks = static_cast<size_t>(std::max(search_.sample_blocks, 1));
  size_t stride = kSampleBlock;
  while ((rows + stride - 1) / stride > blocks) stride *= 2;
  size_t sample = 0;
  for (size_t start = 0; start < rows; start += stride) {
    const size_t end = std::min(rows, start + kSampleBlock);
    for (size_t rank = start; rank < end; ++rank) read[rank] |= 2;
    sample += end - start;
  }
  std::vector<size_t> ranks;
  std::vector<bool> sampled;
  for (size_t rank = 0; rank < rows; ++rank) {
    if (read[rank] == 0) continue;
    ranks.push_back(rank);
    sampled.push_back((read[rank] & 2) != 0);
  }
  scorePaths(run, speeds, ranks, sampled, &scores);
  scores.rows_per_sample =
      static_cast<double>(rows) / static_cast<double>(std::max<size_t>(1, sample));
  return scores;
}

size_t ForeignMap::bytes() const {
  size_t total = vectors_->bytes() + (graph_ ? graph_->bytes() : 0) +
                 rows_.capacity() * sizeof(SharedKeyframe) + ids_.size() * (sizeof(uint64_t) + 32) +
                 (by_id_.capacity() + rank_.capacity()) * sizeof(size_t);
  for (const SharedKeyframe& row : rows_) {
    total += row.robot.capacity() + row.odometry_frame.capacity();
  }
  return total;
}

}  // namespace landmark_loop_closure
