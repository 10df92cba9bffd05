// LoopDetector's acceptance stage: the shortlist re-ranked (or scored as sequences), then the
// threshold, the odometry gate, temporal consistency, the calibrated decision
// (calibrated_decision.cpp) and verification (loop_verification.cpp), in that order.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "landmark_loop_closure/common/stopwatch.h"
#include "landmark_loop_closure/core/loop_detector.h"
#include "landmark_loop_closure/core/place_distinctiveness.h"

namespace landmark_loop_closure {

void LoopDetector::decide(KeyframeResult* result, const ImageDescriptor& descriptor,
                          const QueryResult& query, const KeyframeRecord& query_keyframe,
                          const CameraIntrinsics& intrinsics) {
  if (query.status != QueryStatus::kSearched) {
    consistency_.reset();
    return;
  }
  const auto rerank_start = Clock::now();
  std::vector<CandidateReport>& reports = result->candidates;
  std::vector<size_t> indices;
  for (const Candidate& candidate : query.candidates) {
    const KeyframeSummary& stored = database().summary(candidate.index);
    CandidateReport report;
    report.match_id = stored.id;
    report.match_stamp = stored.stamp;
    report.global_score = candidate.global_score;
    report.score = describer_.extractor().globalScore(candidate.global_score);
    report.image_score = report.score;
    if (describer_.extractor().reranks()) {
      const std::shared_ptr<const KeyframeRecord> record = database().record(candidate.index);
      if (!record) {
        report.verdict = CandidateVerdict::kUnreadable;
        report.detail = "its record could not be read from the map";
        reports.push_back(report);
        indices.push_back(candidate.index);
        continue;
      }
      report.score = describer_.extractor().similarity(descriptor, record->descriptor);
    }
    report.image_score = report.score;
    reports.push_back(report);
    indices.push_back(candidate.index);
  }
  normaliseScores(&reports, descriptor, indices, query_keyframe.stamp);
  if (options_.acceptance.sequence.enabled() &&
      !scoreSequences(&reports, descriptor, indices, query_keyframe.stamp)) {
    result->times.rerank_ms = millisecondsSince(rerank_start);
    return;
  }
  std::stable_sort(
      reports.begin(), reports.end(),
      [](const CandidateReport& a, const CandidateReport& b) { return a.score > b.score; });
  result->times.rerank_ms = millisecondsSince(rerank_start);
  decision_.record(query_keyframe, decisionContext());
  rateDistinctiveness(&reports);

  std::vector<PathPoint> above_threshold;
  for (CandidateReport& report : reports) {
    if (report.score < options_.acceptance.min_score) continue;
    if (report.verdict == CandidateVerdict::kUnreadable) continue;
    if (report.place_ratio < options_.acceptance.min_place_ratio) {
      report.verdict = CandidateVerdict::kAmbiguous;
      std::ostringstream detail;
      detail.precision(2);
      detail << std::fixed << report.place_ratio << " times the best other place's score, under "
             << options_.acceptance.min_place_ratio;
      report.detail = detail.str();
      continue;
    }
    const KeyframeSummary* match = database().findSummary(report.match_id);
    // Earlier sessions' odometry is another frame with its own drift: nothing to compare.
    if (mode_ == DetectorMode::kMapping && match->session == sessions_.current()) {
      const OdometryGateDecision gate =
          checkOdometry(options_.odometry_gate, query_keyframe.pose, query_keyframe.path,
                        match->pose, match->path);
      if (!gate.consistent) {
        report.verdict = CandidateVerdict::kOdometryRejected;
        report.detail = gate.reason();
        continue;
      }
    }
    above_threshold.push_back({match->id, match->path.metres});
  }
  const std::vector<TemporalConsistency::Chain> chains =
      consistency_.update({query_keyframe.id, query_keyframe.path.metres}, above_threshold);

  size_t chain_index = 0;
  std::optional<CellFeatures> query_cells;
  std::vector<const CandidateReport*> place_leaders;
  for (CandidateReport& report : reports) {
    if (report.score < options_.acceptance.min_score) {
      report.verdict = CandidateVerdict::kBelowThreshold;
      continue;
    }
    if (report.verdict == CandidateVerdict::kOdometryRejected ||
        report.verdict == CandidateVerdict::kUnreadable ||
        report.verdict == CandidateVerdict::kAmbiguous) {
      continue;
    }
    const TemporalConsistency::Chain& chain = chains[chain_index++];
    report.consistent_keyframes = chain.keyframes;
    const CandidateReport* leader = placeLeader(report, place_leaders);
    if (!leader) place_leaders.push_back(&report);
    if (!consistentLongEnough(chain, &report.detail)) {
      report.verdict = CandidateVerdict::kAwaitingConsistency;
    } else if (result->loop) {
      report.verdict = CandidateVerdict::kOutscored;
    } else if (leader && !nearLeader(report, *leader)) {
      // The place's better-scoring keyframes were refused: a keyframe farther along it that
      // happens to pass would put the loop off the place.
      report.verdict = CandidateVerdict::kOutscored;
      report.detail = std::to_string(report.match_id) + " is more than " +
                      std::to_string(options_.acceptance.index_window) +
                      " ids from its place's best candidate " + std::to_string(leader->match_id);
    } else if (!decision_.passes(&report, query_keyframe, decisionContext())) {
      report.verdict = CandidateVerdict::kBelowThreshold;
    } else {
      const std::shared_ptr<const KeyframeRecord> match = database().findRecord(report.match_id);
      if (!match) {
        report.verdict = CandidateVerdict::kUnreadable;
        report.detail = "its record could not be read from the map";
        continue;
      }
      AcceptedLoop loop;
      const auto verify_start = Clock::now();
      const bool verified =
          verify(query_keyframe, *match, intrinsics, &report, &loop, &query_cells);
      result->times.verify_ms += millisecondsSince(verify_start);
      if (!verified) continue;
      report.verdict = CandidateVerdict::kAccepted;
      loop.match_id = match->id;
      loop.match_session = match->session;
      loop.match_stamp = match->stamp;
      loop.match_pose = match->pose;
      loop.global_score = report.global_score;
      loop.rerank_score =
          describer_.extractor().reranks() ? report.image_score : report.global_score;
      loop.score = report.score;
      loop.consistent_keyframes = report.consistent_keyframes;
      result->loop = loop;
      decision_.published(query_keyframe, *match, sessions_.current());
    }
  }
}

const CandidateReport* LoopDetector::placeLeader(
    const CandidateReport& report, const std::vector<const CandidateReport*>& leaders) const {
  const KeyframeSummary* match = database().findSummary(report.match_id);
  for (const CandidateReport* leader : leaders) {
    const KeyframeSummary* other = database().findSummary(leader->match_id);
    if (match && other &&
        sameIdPlace(match->id, match->session, other->id, other->session,
                    static_cast<uint64_t>(options_.acceptance.place_window))) {
      return leader;
    }
  }
  return nullptr;
}

bool LoopDetector::nearLeader(const CandidateReport& report, const CandidateReport& leader) const {
  return idGap(report.match_id, leader.match_id) <=
         static_cast<uint64_t>(options_.acceptance.index_window);
}

void LoopDetector::rateDistinctiveness(std::vector<CandidateReport>* reports) const {
  std::vector<ShortlistEntry> shortlist;
  std::vector<const KeyframeSummary*> summaries;
  std::vector<CandidateReport*> rated;
  for (CandidateReport& report : *reports) {
    const KeyframeSummary* summary = database().findSummary(report.match_id);
    if (!summary || report.verdict == CandidateVerdict::kUnreadable) continue;
    shortlist.push_back({summary->id, summary->session, report.score});
    summaries.push_back(summary);
    rated.push_back(&report);
  }
  // Laps of one run: keyframes the odometry puts within its drift of each other are one place.
  const OdometryGateOptions& gate = options_.odometry_gate;
  const auto could_be_same_place = [&](size_t a, size_t b) {
    if (!gate.enabled) return false;
    return checkOdometry(gate, summaries[a]->pose, summaries[a]->path, summaries[b]->pose,
                         summaries[b]->path)
        .consistent;
  };
  const std::vector<double> ratios = placeRatios(
      shortlist, static_cast<uint64_t>(options_.acceptance.place_window), could_be_same_place);
  for (size_t i = 0; i < rated.size(); ++i) rated[i]->place_ratio = ratios[i];
}

void LoopDetector::normaliseScores(std::vector<CandidateReport>* reports,
                                   const ImageDescriptor& descriptor,
                                   const std::vector<size_t>& indices, double stamp) {
  const ScoreNormalisation normalisation = options_.acceptance.score_normalisation;
  if (normalisation == ScoreNormalisation::kNone) return;
  if (normalisation == ScoreNormalisation::kPreviousKeyframe) {
    const double previous = describer_.extractor().globalScore(
        cosineSimilarity(descriptor.global, describer_.previousGlobal()));
    for (CandidateReport& report : *reports) {
      report.score = previousKeyframeScore(report.score, previous);
    }
    return;
  }
  DatabaseOptions search = options_.database;
  if (mode_ == DetectorMode::kLocalization) search.exclude_recent_keyframes = 0;
  const auto scores_of = [&](const std::vector<size_t>& population) {
    std::vector<double> scores = database().similarities(descriptor.global, population);
    for (double& score : scores) score = describer_.extractor().globalScore(score);
    return scores;
  };
  std::vector<size_t> population;
  if (normalisation == ScoreNormalisation::kZScore) {
    // At most kZScoreSample keyframes spread evenly over the map: the mean and spread are as
    // good, and the cost stays bounded however large the map grows.
    const size_t stride = std::max<size_t>(1, database().size() / kZScoreSample);
    for (size_t index = 0; index < database().size(); index += stride) {
      if (database().eligible(index, stamp, search, sessions_.current()))
        population.push_back(index);
    }
    const Standardisation standardisation = Standardisation::of(scores_of(population));
    if (options_.acceptance.sequence.enabled()) {
      sequence_.standardiseCurrent(standardisation);  // Each path step in its own query's spreads.
      return;
    }
    for (CandidateReport& report : *reports) report.score = standardisation.apply(report.score);
    return;
  }
  const size_t window = static_cast<size_t>(options_.acceptance.contrast_window);
  for (size_t i = 0; i < reports->size() && i < indices.size(); ++i) {
    population.clear();
    const size_t first = indices[i] > window ? indices[i] - window : 0;
    const size_t last = std::min(database().size() - 1, indices[i] + window);
    for (size_t index = first; index <= last; ++index) {
      if (database().eligible(index, stamp, search, sessions_.current()))
        population.push_back(index);
    }
    (*reports)[i].score = standardisedScore((*reports)[i].score, scores_of(population));
  }
}

bool LoopDetector::scoreSequences(std::vector<CandidateReport>* reports,
                                  const ImageDescriptor& descriptor,
                                  const std::vector<size_t>& indices, double stamp) {
  std::vector<SequenceCandidate> candidates;
  for (size_t i = 0; i < reports->size(); ++i) {
    SequenceCandidate candidate;
    candidate.index = indices[i];
    candidate.image_score = (*reports)[i].image_score;
    candidates.push_back(candidate);
  }
  DatabaseOptions search = options_.database;
  if (mode_ == DetectorMode::kLocalization) search.exclude_recent_keyframes = 0;
  sequence_.score(
      database(), describer_.extractor(),
      [&](size_t index) { return database().eligible(index, stamp, search, sessions_.current()); },
      &candidates);
  std::vector<CandidateReport> scored;
  for (size_t i = 0; i < candidates.size(); ++i) {
    const SequenceCandidate& candidate = candidates[i];
    CandidateReport report;
    if (i < reports->size()) {
      report = (*reports)[i];
    } else {
      const KeyframeSummary& stored = database().summary(candidate.index);
      report.match_id = stored.id;
      report.match_stamp = stored.stamp;
      report.global_score = database().similarity(descriptor.global, candidate.index);
      report.image_score = candidate.image_score;
    }
    report.score = candidate.score;
    scored.push_back(report);
  }
  *reports = std::move(scored);
  if (sequence_.full()) return true;
  // Too short a history for a sequence: nothing is believed yet.
  std::stable_sort(
      reports->begin(), reports->end(),
      [](const CandidateReport& a, const CandidateReport& b) { return a.score > b.score; });
  for (CandidateReport& report : *reports) {
    report.verdict = report.score < options_.acceptance.min_score
                         ? CandidateVerdict::kBelowThreshold
                         : CandidateVerdict::kAwaitingConsistency;
    report.detail = "sequence of " + std::to_string(sequence_.history()) + " of " +
                    std::to_string(options_.acceptance.sequence.length) + " keyframes";
  }
  consistency_.reset();
  return false;
}

bool LoopDetector::consistentLongEnough(const TemporalConsistency::Chain& chain,
                                        std::string* detail) const {
  const AcceptanceOptions& acceptance = options_.acceptance;
  if (acceptance.consistency_unit == ConsistencyUnit::kKeyframes) {
    return chain.keyframes >= acceptance.consistent_keyframes;
  }
  if (chain.metres >= acceptance.consistent_distance_m) return true;
  std::ostringstream text;
  text.precision(2);
  text << std::fixed << chain.metres << " of " << acceptance.consistent_distance_m << " m";
  *detail = text.str();
  return false;
}

}  // namespace landmark_loop_closure
