#include "landmark_loop_closure/core/sequence_matching.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

namespace landmark_loop_closure {

std::vector<double> SequenceMatchingOptions::speeds() const {
  std::vector<double> values;
  if (!(speed_step > 0.0)) return {min_speed};
  for (double speed = min_speed; speed <= max_speed + 1e-9; speed += speed_step) {
    values.push_back(speed);
  }
  return values;
}

const ParameterTable<SequenceMatchingOptions>& SequenceMatchingOptions::parameters() {
  using O = SequenceMatchingOptions;
  static const auto table =
      ParameterTable<O>("advanced/acceptance/sequence_", "")
          .integer("length", &O::length, between(1, 100),
                   "L > 1: sequence matching (SeqSLAM-style): a candidate's score becomes the best "
                   "mean similarity along a straight path of the last L keyframes against the "
                   "database keyframes ending at it; min_score applies to that mean, and earlier "
                   "keyframes' candidates, carried forward, join the shortlist. No loop is "
                   "believed before L keyframes have come. 5 was chosen on the first halves of "
                   "Gardens Point and Nordland: mean R@100P 0.60 against 0.52 with L = 1 "
                   "(bench/README.md); 1 = single images.")
          .number("min_speed", &O::min_speed, openBetween(0, 10, true, false),
                  "database keyframes per query keyframe along a path, slowest ...")
          .evaluationOnly()
          .number("max_speed", &O::max_speed, openBetween(0, 10, true, false),
                  "... and fastest (keyframes are spaced by motion, so revisits run near 1);")
          .evaluationOnly()
          .number("speed_step", &O::speed_step, above(0),
                  "speeds tried from min to max in this step.")
          .evaluationOnly();
  return table;
}

std::string SequenceMatchingOptions::validate() const {
  std::ostringstream errors;
  errors << parameters().check(*this);
  if (!(max_speed >= min_speed)) {
    errors << "advanced/acceptance/sequence_max_speed (" << max_speed
           << ") must be >= advanced/acceptance/sequence_min_speed (" << min_speed << ")\n";
  }
  if (speed_step > 0.0 && (max_speed - min_speed) / speed_step > 100.0) {
    errors << "advanced/acceptance/sequence_speed_step gives more than 100 speeds\n";
  }
  return errors.str();
}

void SequenceMatcher::push(ImageDescriptor descriptor) {
  history_.push_front(Slot{std::move(descriptor), {}, {}, {}, {}, {}});
  while (history_.size() > static_cast<size_t>(std::max(1, options_.length))) history_.pop_back();
}

void SequenceMatcher::standardiseCurrent(const Standardisation& standardisation) {
  if (!history_.empty()) history_.front().standardisation = standardisation;
}

double SequenceMatcher::similarity(Slot* slot, size_t index, const KeyframeDatabase& database,
                                   const DescriptorExtractor& extractor) const {
  const auto found = slot->similarity.find(index);
  if (found != slot->similarity.end()) return found->second;
  // Encoded once per keyframe: encoding costs more than the product it feeds.
  if (slot->encoded.row.empty()) slot->encoded = database.encode(slot->descriptor.global);
  double value = extractor.globalScore(database.similarity(slot->encoded, index));
  if (extractor.reranks()) {
    const std::shared_ptr<const KeyframeRecord> stored = database.record(index);
    value = stored ? extractor.similarity(slot->descriptor, stored->descriptor) : -1.0;
  }
  slot->similarity.emplace(index, value);
  return value;
}

void SequenceMatcher::score(const KeyframeDatabase& database, const DescriptorExtractor& extractor,
                            const std::function<bool(size_t index)>& eligible,
                            std::vector<SequenceCandidate>* candidates) {
  if (history_.empty()) return;
  Slot& current = history_.front();
  std::set<size_t> present;
  for (const SequenceCandidate& candidate : *candidates) {
    present.insert(candidate.index);
    current.similarity.emplace(candidate.index, candidate.image_score);
  }
  // Where the earlier keyframes' candidates lead now, at speed 1.
  for (size_t back = 1; back < history_.size(); ++back) {
    for (const size_t earlier : history_[back].candidates) {
      const size_t index = earlier + back;
      if (index >= database.size() || present.count(index) || !eligible(index)) continue;
      present.insert(index);
      SequenceCandidate projected;
      projected.index = index;
      projected.image_score = similarity(&current, index, database, extractor);
      projected.projected = true;
      candidates->push_back(projected);
    }
  }
  for (SequenceCandidate& candidate : *candidates) {
    candidate.score = bestPath(candidate.index, database, extractor, &candidate.speed);
  }
  current.candidates.clear();
  for (const SequenceCandidate& candidate : *candidates) {
    if (!candidate.projected) current.candidates.push_back(candidate.index);
  }
}

double SequenceMatcher::bestPath(size_t index, const KeyframeDatabase& database,
                                 const DescriptorExtractor& extractor, double* best_speed) {
  double best = -1.0;
  for (const double speed : options_.speeds()) {
    double sum = 0.0;
    bool complete = true;
    for (size_t slot = 0; slot < history_.size(); ++slot) {
      const long position = static_cast<long>(index) -
                            static_cast<long>(std::lround(static_cast<double>(slot) * speed));
      if (position < 0) {
        complete = false;
        break;
      }
      Slot* earlier = &history_[slot];
      sum += earlier->standardisation.apply(
          similarity(earlier, static_cast<size_t>(position), database, extractor));
    }
    if (!complete) continue;
    const double mean = sum / static_cast<double>(history_.size());
    if (mean > best) {
      best = mean;
      if (best_speed) *best_speed = speed;
    }
  }
  return best;
}

double SequenceMatcher::pathScore(size_t index, const KeyframeDatabase& database,
                                  const DescriptorExtractor& extractor) {
  if (history_.empty() || index >= database.size()) return -1.0;
  return bestPath(index, database, extractor, nullptr);
}

std::vector<float>& SequenceMatcher::blockRow(Slot* slot, size_t block_start, size_t margin) {
  std::vector<float>& row = slot->blocks[block_start];
  if (row.size() != kBackgroundBlock + margin) row.assign(kBackgroundBlock + margin, std::nanf(""));
  return row;
}

double SequenceMatcher::blockSimilarity(Slot* slot, float* value, size_t index,
                                        const KeyframeDatabase& database,
                                        const DescriptorExtractor& extractor) const {
  if (std::isnan(*value)) {
    if (slot->encoded.row.empty()) slot->encoded = database.encode(slot->descriptor.global);
    *value = static_cast<float>(extractor.globalScore(database.similarity(slot->encoded, index)));
  }
  return slot->standardisation.apply(*value);
}

ScoreBackground SequenceMatcher::background(const KeyframeDatabase& database,
                                            const DescriptorExtractor& extractor,
                                            const std::function<bool(size_t index)>& eligible) {
  ScoreBackground result;
  const size_t size = database.size();
  if (history_.empty() || size == 0) return result;
  // Blocks start at multiples of a stride that doubles as the map grows: the same positions are
  // sampled from one keyframe to the next, and the older slots' similarities are reused.
  size_t stride = kBackgroundBlock;
  while ((size + stride - 1) / stride > kBackgroundBlocks) stride *= 2;
  const std::vector<double> speeds = options_.speeds();
  const size_t slots = history_.size();
  // Each slot keeps its blocks while it ages through the history, so their margin is the full
  // history's from the first keyframe on: one laid out for a shorter history would be read at
  // other offsets, and past its end, once the history is full.
  const size_t margin = static_cast<size_t>(std::lround(
      static_cast<double>(std::max(1, options_.length) - 1) * std::max(1.0, options_.max_speed)));
  for (Slot& slot : history_) {
    // Blocks of a smaller stride are not read again once the map has grown past it.
    if (slot.blocks.size() > 2 * kBackgroundBlocks) slot.blocks.clear();
  }
  // Each path's step back per slot, by speed, and each slot's row of the block, are looked up
  // once per call and once per block rather than once per position (the lookups were most of
  // the background's time).
  std::vector<std::vector<long>> steps(speeds.size(), std::vector<long>(slots));
  for (size_t k = 0; k < speeds.size(); ++k) {
    for (size_t slot = 0; slot < slots; ++slot) {
      steps[k][slot] = std::lround(static_cast<double>(slot) * speeds[k]);
    }
  }
  std::vector<float*> rows(slots);
  size_t sampled = 0;
  for (size_t start = 0; start < size; start += stride) {
    const size_t end = std::min(size, start + kBackgroundBlock);
    for (size_t slot = 0; slot < slots; ++slot) {
      rows[slot] = blockRow(&history_[slot], start, margin).data();
    }
    for (size_t index = start; index < end; ++index) {
      ++sampled;
      if (!eligible(index)) continue;
      double best = -HUGE_VAL;
      for (size_t k = 0; k < speeds.size(); ++k) {
        double sum = 0.0;
        bool complete = true;
        for (size_t slot = 0; slot < slots; ++slot) {
          const long step = steps[k][slot];
          if (static_cast<long>(index) < step) {
            complete = false;
            break;
          }
          const size_t position = index - static_cast<size_t>(step);
          sum += blockSimilarity(&history_[slot], rows[slot] + (position + margin - start),
                                 position, database, extractor);
        }
        if (complete) best = std::max(best, sum / static_cast<double>(slots));
        if (slots == 1) break;  // One keyframe: every speed reads the same similarity.
      }
      if (best == -HUGE_VAL) continue;
      result.index.push_back(index);
      result.score.push_back(best);
    }
  }
  result.places = sampled == 0 ? 0
                               : static_cast<size_t>(std::llround(
                                     static_cast<double>(result.index.size()) *
                                     static_cast<double>(size) / static_cast<double>(sampled)));
  return result;
}

}  // namespace landmark_loop_closure
