#pragma once

#include <cstddef>
#include <deque>
#include <functional>
#include <string>
#include <unordered_map>
#include <vector>

#include "landmark_loop_closure/common/parameter_table.h"
#include "landmark_loop_closure/core/score_normalisation.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {

/// SeqSLAM-style scoring (methods.md, seed 004's temporal consistency generalised): a candidate's
/// score is the best mean similarity along a straight path of the last `length` query keyframes
/// against database keyframes ending at the candidate, over a range of relative speeds.
/// Keyframes are spaced by motion, so a revisit at any driving speed runs near speed 1.
struct SequenceMatchingOptions {
  int length = 5;            ///< L keyframes per path; 1 = single-image scores (off).
  double min_speed = 0.5;    ///< Database keyframes per query keyframe, slowest path ...
  double max_speed = 2.0;    ///< ... and fastest.
  double speed_step = 0.25;  ///< Speeds tried: min_speed, min_speed + step, ..., max_speed.

  bool enabled() const { return length > 1; }
  std::vector<double> speeds() const;
  /// Keys acceptance/sequence_*, documented in config/default.yaml.
  static const ParameterTable<SequenceMatchingOptions>& parameters();
  std::string validate() const;  ///< Empty when valid.
};

/// One candidate as the sequence matcher sees it: its database position and scores.
struct SequenceCandidate {
  size_t index = 0;          ///< Position in the database.
  double image_score = 0.0;  ///< The current keyframe's own similarity to it (not standardised).
  double score = 0.0;        ///< Best path mean (set by SequenceMatcher::score).
  double speed = 0.0;        ///< The path's speed.
  bool projected = false;    ///< Added from an earlier keyframe's candidate, not the shortlist.
};

/// What the places of the map score against the current keyframe, each as a candidate would
/// (SequenceMatcher::background).
struct ScoreBackground {
  std::vector<size_t> index;  ///< Sampled database positions that were eligible.
  std::vector<double> score;  ///< Their best path scores, in the same order.
  size_t places = 0;          ///< Eligible positions in the whole map (estimated from the sample).
};

class SequenceMatcher {
 public:
  /// Sampled positions per background: blocks of kBackgroundBlock contiguous positions spread
  /// evenly over the map, at most kBackgroundBlocks of them.
  static constexpr size_t kBackgroundBlock = 32;
  static constexpr size_t kBackgroundBlocks = 32;

  explicit SequenceMatcher(const SequenceMatchingOptions& options = {}) : options_(options) {}

  /// Appends the new query keyframe (slot 0 from now on); older ones shift back.
  void push(ImageDescriptor descriptor);
  /// Scores the current keyframe's similarities in spreads of its own similarities to the map
  /// (score_normalisation z_score): a path's mean is then a mean of standardised similarities,
  /// each query keyframe measured against what it resembles anyway.
  void standardiseCurrent(const Standardisation& standardisation);
  /// Forgets the history (reset, another map, time jumped back).
  void reset() { history_.clear(); }
  /// Query keyframes held (at most length).
  size_t history() const { return history_.size(); }
  bool full() const { return history_.size() >= static_cast<size_t>(options_.length); }

  /// Adds, to the current keyframe's candidates, the places earlier keyframes' candidates lead
  /// to at speed 1 (when `eligible` allows them), then scores each by its best path. A path
  /// stops at the database's start and at the history's end (its mean covers what it has).
  /// Remembers the final candidate positions for the next keyframes' projections.
  /// `similarity(slot, index)`: slot 0 = the current keyframe.
  void score(const KeyframeDatabase& database, const DescriptorExtractor& extractor,
             const std::function<bool(size_t index)>& eligible,
             std::vector<SequenceCandidate>* candidates);
  /// Every sampled eligible position's best path score, as score() scores a candidate (with
  /// length 1, the current keyframe's similarity). Samples the whole map up to
  /// kBackgroundBlock * kBackgroundBlocks positions; a larger map in blocks spread evenly, whose
  /// positions stay put as it grows, so earlier keyframes' similarities are computed once. Global
  /// similarities only: not for a descriptor that re-ranks.
  ScoreBackground background(const KeyframeDatabase& database, const DescriptorExtractor& extractor,
                             const std::function<bool(size_t index)>& eligible);
  /// The best path score ending at `index`, as score() scores a candidate there, whether or not
  /// it is eligible; remembers nothing for projection. -1 without history.
  double pathScore(size_t index, const KeyframeDatabase& database,
                   const DescriptorExtractor& extractor);

 private:
  struct Slot {
    ImageDescriptor descriptor;
    std::vector<size_t> candidates;                 ///< Its database positions, for projection.
    std::unordered_map<size_t, double> similarity;  ///< Similarities already computed, by position.
    KeyframeDatabase::EncodedQuery encoded;         ///< The descriptor as search compares it.
    Standardisation standardisation;                ///< Identity unless standardiseCurrent.
    /// Similarities to background blocks, by block start: positions start - margin to
    /// start + kBackgroundBlock, NaN until computed.
    std::unordered_map<size_t, std::vector<float>> blocks;
  };
  /// The best mean over the speeds of the path ending at `index` (-1 when no path is complete);
  /// its speed in `best_speed` when given.
  double bestPath(size_t index, const KeyframeDatabase& database,
                  const DescriptorExtractor& extractor, double* best_speed);
  /// Slot's row for the block at `block_start` (positions block_start - margin on), made when
  /// missing.
  static std::vector<float>& blockRow(Slot* slot, size_t block_start, size_t margin);
  /// Slot's similarity to `index`, read from (or computed into) `value`, its place in a blockRow.
  double blockSimilarity(Slot* slot, float* value, size_t index, const KeyframeDatabase& database,
                         const DescriptorExtractor& extractor) const;
  /// The slot's similarity to a database keyframe, not standardised.
  double similarity(Slot* slot, size_t index, const KeyframeDatabase& database,
                    const DescriptorExtractor& extractor) const;

  SequenceMatchingOptions options_;
  std::deque<Slot> history_;  ///< Front: the newest keyframe.
};

}  // namespace landmark_loop_closure
