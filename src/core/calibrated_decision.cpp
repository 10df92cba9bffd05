#include "landmark_loop_closure/core/calibrated_decision.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "landmark_loop_closure/core/odometry_gate.h"
#include "landmark_loop_closure/core/place_distinctiveness.h"

namespace landmark_loop_closure {

CalibratedDecision::CalibratedDecision(const LoopDetectorOptions& options)
    : acceptance_(options.acceptance),
      gate_(options.odometry_gate),
      database_options_(options.database) {}

bool CalibratedDecision::appliesTo(const DescriptorExtractor& extractor) const {
  return acceptance_.max_false_alarms > 0.0 && !extractor.reranks();
}

void CalibratedDecision::reset() {
  backgrounds_.clear();
  background_places_ = 0;
  passed_places_.clear();
  last_loop_.reset();
}

void CalibratedDecision::record(const KeyframeRecord& query, const DecisionContext& context) {
  if (!appliesTo(context.extractor)) return;
  const KeyframeDatabase& database = context.database;
  DatabaseOptions search = database_options_;
  if (context.mode == DetectorMode::kLocalization) search.exclude_recent_keyframes = 0;
  const ScoreBackground background = context.sequences.background(
      database, context.extractor,
      [&](size_t index) { return database.eligible(index, query.stamp, search, context.session); });
  std::vector<PlaceScore> scores;
  scores.reserve(background.index.size());
  for (size_t j = 0; j < background.index.size(); ++j) {
    const KeyframeSummary& place = database.summary(background.index[j]);
    scores.push_back({place.id, place.session, background.score[j]});
  }
  backgrounds_.push_front(std::move(scores));
  while (backgrounds_.size() > kPooledBackgrounds) backgrounds_.pop_back();
  background_places_ = background.places;
  const uint64_t span = static_cast<uint64_t>(database_options_.exclude_recent_keyframes);
  if (context.mode != DetectorMode::kMapping || span == 0) return;
  std::vector<double> passed;
  for (size_t index = database.size(); index-- > 0;) {
    const KeyframeSummary& place = database.summary(index);
    if (place.session != context.session || place.id >= query.id) break;
    if (!justPassed(place, query.id, context.session)) {
      if (query.id - place.id > 2 * span) break;
      continue;
    }
    passed.push_back(context.sequences.pathScore(index, database, context.extractor));
  }
  passed_places_.add(std::move(passed));
}

bool CalibratedDecision::justPassed(const KeyframeSummary& match, uint64_t query_id,
                                    uint32_t session) const {
  if (match.session != session || match.id >= query_id) return false;
  const uint64_t span = static_cast<uint64_t>(database_options_.exclude_recent_keyframes);
  const uint64_t gap = query_id - match.id;
  return gap > span && gap <= 2 * span;
}

bool CalibratedDecision::passes(CandidateReport* report, const KeyframeRecord& query,
                                const DecisionContext& context) {
  if (!appliesTo(context.extractor)) return true;
  const bool mapping = context.mode == DetectorMode::kMapping;
  // Not evidence of what a wrong place scores: the candidate's own place, and places the
  // odometry puts within its drift of the query (laps of one run revisit them).
  const KeyframeSummary* match = context.database.findSummary(report->match_id);
  const uint64_t window = static_cast<uint64_t>(acceptance_.place_window);
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
      if (gate_.enabled && mapping && place.session == context.session) {
        const KeyframeSummary* summary = context.database.findSummary(place.id);
        reachable =
            summary &&
            checkOdometry(gate_, query.pose, query.path, summary->pose, summary->path).consistent;
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
  const bool continues = match && continuesLastLoop(*match, query.id, context.session);
  // Only a stretch that keeps up with the query continues on fewer cells: a match behind the
  // last one, or on it for a second keyframe (or after a gap), is falling behind its place (the
  // neighbour a loop must not name) and is checked as any other candidate.
  const bool stands = continues && match->id == last_loop_->match_id &&
                      (last_loop_->stood || query.id > last_loop_->query_id + 1);
  report->continues_loop = continues && match->id >= last_loop_->match_id && !stands;
  // Continuing the last loop, it is one of the few places that would continue it.
  const size_t tested =
      continues ? std::min(places, 2 * static_cast<size_t>(acceptance_.index_window) + 1) : places;
  report->false_alarms = tail.expectedFalseAlarms(report->score, tested);
  report->false_alarm_places = tested;
  const double limit = bound(match, query, context);
  if (match && mapping && justPassed(*match, query.id, context.session)) {
    // Among the places just passed it must also stand out of what they score.
    const ScoreTail passed = passed_places_.tail();
    if (!passed.valid()) {
      detail << "among the places just passed, and too few of their scores yet ("
             << passed_places_.samples() << ") to tell what they score here";
      report->detail = detail.str();
      return false;
    }
    const size_t span = static_cast<size_t>(database_options_.exclude_recent_keyframes);
    const double passed_alarms = passed.expectedFalseAlarms(report->score, span);
    // The larger estimate also sets the cells the appearance check asks of a passing candidate.
    report->false_alarms = std::max(report->false_alarms, passed_alarms);
    if (passed_alarms > limit) {
      detail.precision(3);
      detail << passed_alarms << " of the " << span
             << " places just passed expected to score as high, more than " << limit
             << " (it needs " << passed.scoreFor(limit, span) << ")";
      report->detail = detail.str();
      return false;
    }
  }
  if (report->false_alarms <= limit) {
    if (!match || match->session != context.session || !mapping) return true;
    return leftThePlace(*match, tail.threshold, context, &report->detail);
  }
  detail.precision(3);
  detail << report->false_alarms << " wrong places expected to score as high among " << tested
         << (continues ? " continuing the last loop" : "") << ", more than " << limit
         << " (it needs " << tail.scoreFor(limit, tested) << ")";
  report->detail = detail.str();
  return false;
}

void CalibratedDecision::published(const KeyframeRecord& query, const KeyframeSummary& match,
                                   uint32_t session) {
  const bool stood = last_loop_ && last_loop_->query_session == session &&
                     last_loop_->query_id + 1 == query.id &&
                     last_loop_->match_session == match.session && last_loop_->match_id >= match.id;
  last_loop_ = PublishedLoop{query.id, session, match.id, match.session, stood};
}

bool CalibratedDecision::continuesLastLoop(const KeyframeSummary& match, uint64_t query_id,
                                           uint32_t session) const {
  return last_loop_ && last_loop_->query_session == session &&
         last_loop_->match_session == match.session &&
         continuesStretch(last_loop_->query_id, last_loop_->match_id, query_id, match.id,
                          acceptance_.index_window, acceptance_.continue_across);
}

double CalibratedDecision::bound(const KeyframeSummary* match, const KeyframeRecord& query,
                                 const DecisionContext& context) const {
  if (acceptance_.max_false_alarms_within_reach <= 0.0 || !match || !gate_.enabled ||
      context.mode != DetectorMode::kMapping || match->session != context.session) {
    return acceptance_.max_false_alarms;
  }
  const bool within_reach =
      checkOdometry(gate_, query.pose, query.path, match->pose, match->path).consistent;
  return within_reach ? acceptance_.max_false_alarms_within_reach : acceptance_.max_false_alarms;
}

bool CalibratedDecision::leftThePlace(const KeyframeSummary& match, double level,
                                      const DecisionContext& context, std::string* detail) const {
  const KeyframeDatabase& database = context.database;
  const std::optional<size_t> start = database.indexOf(match.id);
  if (!start) return true;
  const uint64_t window = static_cast<uint64_t>(acceptance_.place_window);
  double lowest = HUGE_VAL;
  // From the match onwards: a revisit usually leaves its place within a few keyframes.
  for (size_t index = *start + 1; index < database.size(); ++index) {
    const KeyframeSummary& between = database.summary(index);
    if (between.session != context.session || idGap(between.id, match.id) <= window) continue;
    const double score = context.sequences.pathScore(index, database, context.extractor);
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

}  // namespace landmark_loop_closure
