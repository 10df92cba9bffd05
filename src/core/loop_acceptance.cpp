// LoopDetector's acceptance stage: the shortlist re-ranked (or scored as sequences), then the
// threshold, the odometry gate, temporal consistency and verification (loop_verification.cpp),
// in that order.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "landmark_loop_closure/common/stopwatch.h"
#include "landmark_loop_closure/core/false_alarms.h"
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
    report.score = extractor_->globalScore(candidate.global_score);
    report.image_score = report.score;
    if (extractor_->reranks()) {
      const std::shared_ptr<const KeyframeRecord> record = database().record(candidate.index);
      if (!record) {
        report.verdict = CandidateVerdict::kUnreadable;
        report.detail = "its record could not be read from the map";
        reports.push_back(report);
        indices.push_back(candidate.index);
        continue;
      }
      report.score = extractor_->similarity(descriptor, record->descriptor);
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
  recordBackground(query_keyframe);
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
    if (mode_ == DetectorMode::kMapping && match->session == session_) {
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
    } else if (!passesFalseAlarms(&report, query_keyframe)) {
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
      loop.rerank_score = extractor_->reranks() ? report.image_score : report.global_score;
      loop.score = report.score;
      loop.consistent_keyframes = report.consistent_keyframes;
      result->loop = loop;
      const bool stood = last_loop_ && last_loop_->query_session == session_ &&
                         last_loop_->query_id + 1 == query_keyframe.id &&
                         last_loop_->match_session == match->session &&
                         last_loop_->match_id >= match->id;
      last_loop_ = PublishedLoop{query_keyframe.id, session_, match->id, match->session, stood};
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

bool LoopDetector::calibrates() const {
  return options_.acceptance.max_false_alarms > 0.0 && !extractor_->reranks();
}

void LoopDetector::recordBackground(const KeyframeRecord& query_keyframe) {
  if (!calibrates()) return;
  DatabaseOptions search = options_.database;
  if (mode_ == DetectorMode::kLocalization) search.exclude_recent_keyframes = 0;
  const ScoreBackground background =
      sequence_.background(database(), *extractor_, [&](size_t index) {
        return database().eligible(index, query_keyframe.stamp, search, session_);
      });
  std::vector<PlaceScore> scores;
  scores.reserve(background.index.size());
  for (size_t j = 0; j < background.index.size(); ++j) {
    const KeyframeSummary& place = database().summary(background.index[j]);
    scores.push_back({place.id, place.session, background.score[j]});
  }
  backgrounds_.push_front(std::move(scores));
  while (backgrounds_.size() > kPooledBackgrounds) backgrounds_.pop_back();
  background_places_ = background.places;
  const uint64_t span = static_cast<uint64_t>(options_.database.exclude_recent_keyframes);
  if (mode_ != DetectorMode::kMapping || span == 0) return;
  std::vector<double> passed;
  for (size_t index = database().size(); index-- > 0;) {
    const KeyframeSummary& place = database().summary(index);
    if (place.session != session_ || place.id >= query_keyframe.id) break;
    if (!justPassed(place, query_keyframe.id)) {
      if (query_keyframe.id - place.id > 2 * span) break;
      continue;
    }
    passed.push_back(sequence_.pathScore(index, database(), *extractor_));
  }
  passed_places_.add(std::move(passed));
}

bool LoopDetector::justPassed(const KeyframeSummary& match, uint64_t query_id) const {
  if (match.session != session_ || match.id >= query_id) return false;
  const uint64_t span = static_cast<uint64_t>(options_.database.exclude_recent_keyframes);
  const uint64_t gap = query_id - match.id;
  return gap > span && gap <= 2 * span;
}

bool LoopDetector::passesFalseAlarms(CandidateReport* report,
                                     const KeyframeRecord& query_keyframe) {
  if (!calibrates()) return true;
  // Not evidence of what a wrong place scores: the candidate's own place, and places the
  // odometry puts within its drift of the query (laps of one run revisit them).
  const OdometryGateOptions& gate = options_.odometry_gate;
  const KeyframeSummary* match = database().findSummary(report->match_id);
  const uint64_t window = static_cast<uint64_t>(options_.acceptance.place_window);
  std::vector<double> others;
  // Places that could be mistaken for the query's: those the odometry does not rule out. The
  // gate refuses the others whatever they score, so they count as evidence of what a wrong
  // place scores, not as chances of a false alarm.
  size_t newest_searchable = 0;
  for (size_t b = 0; b < backgrounds_.size(); ++b) {
    for (const PlaceScore& place : backgrounds_[b]) {
      if (match && sameIdPlace(place.id, place.session, match->id, match->session, window)) {
        continue;
      }
      bool reachable = true;
      if (gate.enabled && mode_ == DetectorMode::kMapping && place.session == session_) {
        const KeyframeSummary* summary = database().findSummary(place.id);
        reachable = summary && checkOdometry(gate, query_keyframe.pose, query_keyframe.path,
                                             summary->pose, summary->path)
                                   .consistent;
        // Within the odometry's reach it may be the query's own place (laps of one run).
        if (!reachable) others.push_back(place.score);
      } else {
        others.push_back(place.score);
      }
      if (b == 0 && reachable) ++newest_searchable;
    }
  }
  const ScoreTail tail = fitScoreTail(others);
  std::ostringstream detail;
  if (!tail.valid()) {
    detail << "too few other places (" << others.size()
           << ") to tell what a wrong match scores here";
    report->detail = detail.str();
    return false;
  }
  // The newest background's searchable share of the map's eligible places, at least one.
  const size_t sampled = backgrounds_.empty() ? 0 : backgrounds_.front().size();
  const size_t places =
      sampled == 0
          ? 1
          : std::max<size_t>(
                1, static_cast<size_t>(std::llround(static_cast<double>(background_places_) *
                                                    static_cast<double>(newest_searchable) /
                                                    static_cast<double>(sampled))));
  const bool continues = match && continuesLastLoop(*match, query_keyframe.id);
  // Only a stretch that keeps up with the query continues on fewer cells: a match behind the
  // last one, or on it for a second keyframe, is falling behind its place (the neighbour a
  // loop must not name) and is checked as any other candidate.
  report->continues_loop = continues && match->id >= last_loop_->match_id &&
                           !(last_loop_->stood && last_loop_->match_id == match->id);
  // Continuing the last keyframe's loop, it is one of the few places that would continue it.
  const size_t tested =
      continues ? std::min(places, 2 * static_cast<size_t>(options_.acceptance.index_window) + 1)
                : places;
  report->false_alarms = tail.expectedFalseAlarms(report->score, tested);
  report->false_alarm_places = tested;
  const double bound = falseAlarmBound(match, query_keyframe);
  if (match && mode_ == DetectorMode::kMapping && justPassed(*match, query_keyframe.id)) {
    // Among the places just passed it must also stand out of what they score.
    const ScoreTail passed = passed_places_.tail();
    if (!passed.valid()) {
      detail << "among the places just passed, and too few of their scores yet ("
             << passed_places_.samples() << ") to tell what they score here";
      report->detail = detail.str();
      return false;
    }
    const size_t span = static_cast<size_t>(options_.database.exclude_recent_keyframes);
    const double passed_alarms = passed.expectedFalseAlarms(report->score, span);
    // The larger estimate also sets the cells the appearance check asks of a passing candidate.
    report->false_alarms = std::max(report->false_alarms, passed_alarms);
    if (passed_alarms > bound) {
      detail.precision(3);
      detail << passed_alarms << " of the " << span
             << " places just passed expected to score as high, more than " << bound
             << " (it needs " << passed.scoreFor(bound, span) << ")";
      report->detail = detail.str();
      return false;
    }
  }
  if (report->false_alarms <= bound) {
    if (!match || match->session != session_ || mode_ != DetectorMode::kMapping) return true;
    return leftThePlace(*match, tail.threshold, &report->detail);
  }
  detail.precision(3);
  detail << report->false_alarms << " wrong places expected to score as high among " << tested
         << (continues ? " continuing the last loop" : "") << ", more than " << bound
         << " (it needs " << tail.scoreFor(bound, tested) << ")";
  report->detail = detail.str();
  return false;
}

bool LoopDetector::continuesLastLoop(const KeyframeSummary& match, uint64_t query_id) const {
  return last_loop_ && last_loop_->query_session == session_ &&
         last_loop_->query_id + 1 == query_id && last_loop_->match_session == match.session &&
         idGap(match.id, last_loop_->match_id) <=
             static_cast<uint64_t>(options_.acceptance.index_window);
}

double LoopDetector::falseAlarmBound(const KeyframeSummary* match,
                                     const KeyframeRecord& query_keyframe) const {
  const AcceptanceOptions& acceptance = options_.acceptance;
  const OdometryGateOptions& gate = options_.odometry_gate;
  if (acceptance.max_false_alarms_within_reach <= 0.0 || !match || !gate.enabled ||
      mode_ != DetectorMode::kMapping || match->session != session_) {
    return acceptance.max_false_alarms;
  }
  const bool within_reach =
      checkOdometry(gate, query_keyframe.pose, query_keyframe.path, match->pose, match->path)
          .consistent;
  return within_reach ? acceptance.max_false_alarms_within_reach : acceptance.max_false_alarms;
}

bool LoopDetector::leftThePlace(const KeyframeSummary& match, double level, std::string* detail) {
  const std::optional<size_t> start = database().indexOf(match.id);
  if (!start) return true;
  const uint64_t window = static_cast<uint64_t>(options_.acceptance.place_window);
  double lowest = HUGE_VAL;
  // From the match onwards: a revisit usually leaves its place within a few keyframes.
  for (size_t index = *start + 1; index < database().size(); ++index) {
    const KeyframeSummary& between = database().summary(index);
    if (between.session != session_ || idGap(between.id, match.id) <= window) continue;
    const double score = sequence_.pathScore(index, database(), *extractor_);
    if (score <= level) return true;
    lowest = std::min(lowest, score);
  }
  if (lowest == HUGE_VAL) {
    *detail = "not a revisit: the query has not left its place (no keyframe of this run between)";
    return false;
  }
  std::ostringstream text;
  text.precision(3);
  text << "not a revisit: every keyframe of this run since its place scores at least " << lowest
       << " against the query, above what other places score (" << level << ")";
  *detail = text.str();
  return false;
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
    const double previous =
        extractor_->globalScore(cosineSimilarity(descriptor.global, previous_global_));
    for (CandidateReport& report : *reports) {
      report.score = previousKeyframeScore(report.score, previous);
    }
    return;
  }
  DatabaseOptions search = options_.database;
  if (mode_ == DetectorMode::kLocalization) search.exclude_recent_keyframes = 0;
  const auto scores_of = [&](const std::vector<size_t>& population) {
    std::vector<double> scores = database().similarities(descriptor.global, population);
    for (double& score : scores) score = extractor_->globalScore(score);
    return scores;
  };
  std::vector<size_t> population;
  if (normalisation == ScoreNormalisation::kZScore) {
    // At most kZScoreSample keyframes spread evenly over the map: the mean and spread are as
    // good, and the cost stays bounded however large the map grows.
    const size_t stride = std::max<size_t>(1, database().size() / kZScoreSample);
    for (size_t index = 0; index < database().size(); index += stride) {
      if (database().eligible(index, stamp, search, session_)) population.push_back(index);
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
      if (database().eligible(index, stamp, search, session_)) population.push_back(index);
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
      database(), *extractor_,
      [&](size_t index) { return database().eligible(index, stamp, search, session_); },
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
