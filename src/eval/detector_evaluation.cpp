#include "landmark_loop_closure/eval/detector_evaluation.h"

#include "landmark_loop_closure/common/durable_file.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <unordered_map>

#include "landmark_loop_closure/common/thread_annotations.h"
#include "landmark_loop_closure/eval/report.h"

namespace landmark_loop_closure {
namespace eval {

namespace {

// The image's bytes and shape hashed (FNV-1a over 64-bit words): the same frame played again
// gets the same key.
uint64_t imageKey(const cv::Mat& image) {
  uint64_t hash = 1469598103934665603ull;
  const auto mix = [&hash](uint64_t value) {
    hash ^= value;
    hash *= 1099511628211ull;
  };
  mix(static_cast<uint64_t>(image.rows) << 32 | static_cast<uint64_t>(image.cols));
  mix(static_cast<uint64_t>(image.type()));
  const size_t row_bytes = image.cols * image.elemSize();
  for (int r = 0; r < image.rows; ++r) {
    const uint8_t* row = image.ptr<uint8_t>(r);
    size_t i = 0;
    for (; i + 8 <= row_bytes; i += 8) {
      uint64_t word;
      std::memcpy(&word, row + i, 8);
      mix(word);
    }
    for (; i < row_bytes; ++i) mix(row[i]);
  }
  return hash;
}

// Describes each distinct image once (and computes each thumbnail's appearance maps once); later
// passes of the sweep get the stored results.
class CachedExtractor : public DescriptorExtractor {
 public:
  explicit CachedExtractor(std::shared_ptr<const DescriptorExtractor> inner)
      : inner_(std::move(inner)) {}
  std::string name() const override { return inner_->name(); }
  int globalDimension() const override { return inner_->globalDimension(); }
  ImageDescriptor describe(const cv::Mat& image) const override {
    return cached(&descriptors_, image, [this](const cv::Mat& m) { return inner_->describe(m); });
  }
  double similarity(const ImageDescriptor& query, const ImageDescriptor& candidate) const override {
    return inner_->similarity(query, candidate);
  }
  double globalScore(double cosine) const override { return inner_->globalScore(cosine); }
  bool reranks() const override { return inner_->reranks(); }
  bool wantsColour() const override { return inner_->wantsColour(); }
  FeatureMaps appearanceMaps(const cv::Mat& image) const override {
    return cached(&maps_, image, [this](const cv::Mat& m) { return inner_->appearanceMaps(m); });
  }

 private:
  // The stored value for `image`'s bytes, computed outside the lock when absent.
  template <typename Value, typename Compute>
  Value cached(std::unordered_map<uint64_t, Value>* cache, const cv::Mat& image,
               const Compute& compute) const {
    const uint64_t key = imageKey(image);
    {
      MutexLock lock(mutex_);
      const auto found = cache->find(key);
      if (found != cache->end()) return found->second;
    }
    Value value = compute(image);
    MutexLock lock(mutex_);
    cache->emplace(key, value);
    return value;
  }

  std::shared_ptr<const DescriptorExtractor> inner_;
  mutable Mutex mutex_;
  mutable std::unordered_map<uint64_t, ImageDescriptor> descriptors_ GUARDED_BY(mutex_);
  /// Of thumbnails.
  mutable std::unordered_map<uint64_t, FeatureMaps> maps_ GUARDED_BY(mutex_);
};

struct PassInput {
  RunProtocol protocol;
  std::shared_ptr<LoopDetector::QueryCache> queries;
  const LoopDetectorOptions* options;
  std::shared_ptr<const DescriptorExtractor> extractor;
  const FramePlayer* play;
  const SamePlace* same_place;
};

// One pass at `min_score`; fills the keyframe bookkeeping of `evaluation` when asked.
DetectorPass runPass(const PassInput& input, double min_score, DetectorEvaluation* evaluation,
                     bool record_keyframes, const Progress& progress) {
  LoopDetectorOptions options = *input.options;
  options.acceptance.min_score = min_score;
  options.database.memory_budget_mb = 0.0;  // Every pass stores every keyframe: queries replay.
  if (!record_keyframes) options.database.index.type = "exact";  // Searches come from the cache.
  LoopDetector detector(options, input.extractor);
  detector.setQueryCache(input.queries);
  DetectorPass pass;
  pass.min_score = min_score;
  std::vector<size_t> keyframe_frames;
  std::vector<Pose> keyframe_poses;
  std::vector<uint32_t> keyframe_sessions;
  size_t frames = 0;
  size_t refused_frames = 0;
  (*input.play)([&](size_t index, const DetectorFrame& frame) {
    ++frames;
    if (frame.new_run && input.protocol == RunProtocol::kSessions) detector.restartOdometry();
    if (frame.new_run && input.protocol == RunProtocol::kLocalisation) {
      detector.setMode(DetectorMode::kLocalization);
    }
    const auto start = std::chrono::steady_clock::now();
    const FrameResult result =
        detector.process(frame.stamp, frame.pose, frame.image, frame.intrinsics);
    if (result.admission.error || (result.keyframe && result.keyframe->error)) {
      ++refused_frames;
      return;
    }
    if (!result.keyframe) return;
    const KeyframeResult& keyframe = *result.keyframe;
    pass.keyframe_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count());
    if (keyframe_frames.size() <= keyframe.keyframe_id) {
      keyframe_frames.resize(keyframe.keyframe_id + 1, 0);
    }
    keyframe_frames[keyframe.keyframe_id] = index;
    if (keyframe_poses.size() <= keyframe.keyframe_id) {
      keyframe_poses.resize(keyframe.keyframe_id + 1);
    }
    keyframe_poses[keyframe.keyframe_id] = frame.pose;
    if (keyframe_sessions.size() <= keyframe.keyframe_id) {
      keyframe_sessions.resize(keyframe.keyframe_id + 1, 0);
    }
    keyframe_sessions[keyframe.keyframe_id] = detector.session();
    if (record_keyframes) {
      for (const CandidateReport& candidate : keyframe.candidates) {
        CandidateRow row;
        row.query_id = keyframe.keyframe_id;
        row.match_id = candidate.match_id;
        row.query_frame = index;
        row.match_frame = keyframe_frames.at(candidate.match_id);
        row.global_score = candidate.global_score;
        row.score = candidate.score;
        row.place_ratio = candidate.place_ratio;
        row.false_alarms = candidate.false_alarms;
        row.detail = candidate.detail;
        row.verdict = toString(candidate.verdict);
        row.correct = (*input.same_place)(row.query_frame, row.match_frame);
        pass.candidates.push_back(row);
      }
    }
    if (keyframe.loop) {
      PublishedLoop loop;
      loop.query_id = keyframe.keyframe_id;
      loop.match_id = keyframe.loop->match_id;
      loop.query_frame = index;
      loop.match_frame = keyframe_frames.at(loop.match_id);
      loop.score = keyframe.loop->score;
      loop.verified = keyframe.loop->verification.has_value();
      loop.correct = (*input.same_place)(loop.query_frame, loop.match_frame);
      const std::optional<RelativePose>& relative = keyframe.loop->relative_pose;
      if (relative && relative->metric) {
        LoopConstraint camera;
        camera.query_id = loop.query_id;
        camera.match_id = loop.match_id;
        camera.query_T_match.linear() = relative->rotation;
        camera.query_T_match.translation() = relative->translation;
        camera.covariance = relative->covariance;
        loop.metric_pose = loopInBaseFrame(camera, options.camera_mount.toPose().toIsometry());
      }
      pass.true_loops += loop.correct ? 1 : 0;
      pass.loops.push_back(loop);
    } else if (keyframe.query_status != QueryStatus::kSearched) {
      ++pass.refused[toString(keyframe.query_status)];
    } else if (!keyframe.candidates.empty()) {
      ++pass.refused[toString(keyframe.candidates.front().verdict)];
    }
    if (progress && record_keyframes && keyframe.keyframe_id % 500 == 0) progress(index, 0);
  });
  if (!pass.loops.empty()) {
    pass.precision = static_cast<double>(pass.true_loops) / static_cast<double>(pass.loops.size());
  }
  if (record_keyframes) {
    evaluation->frames = frames;
    evaluation->refused_frames = refused_frames;
    evaluation->keyframes = pass.keyframe_ms.size();
    evaluation->keyframe_frames = keyframe_frames;
    evaluation->keyframe_poses = keyframe_poses;
    evaluation->keyframe_sessions = keyframe_sessions;
  }
  return pass;
}

void setRecall(DetectorPass* pass, size_t revisits) {
  pass->recall = revisits > 0 ? static_cast<double>(pass->true_loops) / revisits : 0.0;
}

bool clean(const DetectorPass& pass) { return pass.true_loops == pass.loops.size(); }

}  // namespace

namespace {

// A CSV field: quoted, inner quotes doubled (details hold commas).
std::string csvQuoted(const std::string& text) {
  std::string quoted = "\"";
  for (const char c : text) {
    quoted += c;
    if (c == '"') quoted += '"';
  }
  return quoted + "\"";
}

}  // namespace

const char* toString(RunProtocol protocol) {
  switch (protocol) {
    case RunProtocol::kOneSequence:
      return "one-sequence";
    case RunProtocol::kSessions:
      return "sessions";
    case RunProtocol::kLocalisation:
      return "localisation";
    case RunProtocol::kOneRun:
      return "one-run";
    case RunProtocol::kRobots:
      return "robots";
  }
  return "?";
}

RunProtocol runProtocol(const std::string& name) {
  for (const RunProtocol protocol :
       {RunProtocol::kOneSequence, RunProtocol::kSessions, RunProtocol::kLocalisation,
        RunProtocol::kOneRun, RunProtocol::kRobots}) {
    if (name == toString(protocol)) return protocol;
  }
  throw std::invalid_argument("unknown protocol '" + name +
                              "' (one-sequence, sessions, localisation, one-run or robots)");
}

DetectorEvaluation evaluateDetector(const LoopDetectorOptions& options,
                                    std::shared_ptr<const DescriptorExtractor> extractor,
                                    const FramePlayer& play, const SamePlace& same_place,
                                    const DetectorEvaluationOptions& evaluation_options,
                                    const Progress& progress) {
  if (evaluation_options.protocol == RunProtocol::kRobots) {
    return evaluateRobots(options, std::move(extractor), play, same_place,
                          evaluation_options.fleet);
  }
  const std::string problems = options.validate();
  if (!problems.empty()) throw std::invalid_argument(problems);
  DetectorEvaluation evaluation;
  const PassInput input{evaluation_options.protocol,
                        std::make_shared<LoopDetector::QueryCache>(),
                        &options,
                        std::make_shared<CachedExtractor>(std::move(extractor)),
                        &play,
                        &same_place};
  evaluation.configured = runPass(input, options.acceptance.min_score, &evaluation, true, progress);
  evaluation.keyframe_ms = percentiles(evaluation.configured.keyframe_ms);

  // Revisits: keyframes with a true place among the earlier keyframes (ids are dense from 0).
  const std::vector<size_t>& frames = evaluation.keyframe_frames;
  for (size_t q = 0; q < frames.size(); ++q) {
    for (size_t m = 0; m < q; ++m) {
      if (same_place(frames[q], frames[m])) {
        ++evaluation.revisits;
        break;
      }
    }
  }
  setRecall(&evaluation.configured, evaluation.revisits);
  if (evaluation_options.sweep_steps == 0) {
    evaluation.recall_at_100_precision = -1.0;  // Not swept: the configured pass alone.
    return evaluation;
  }

  // The sweep: the configured threshold, then a grid from 1 (or the highest candidate score:
  // standardised scores count spreads) down to the lowest final score seen, then bisections
  // where the first false loop appears.
  double lowest = options.acceptance.min_score;
  for (const PublishedLoop& loop : evaluation.configured.loops)
    lowest = std::min(lowest, loop.score);
  lowest = std::max(0.0, lowest - 0.3);  // advanced/acceptance/min_score is at least 0.
  double highest = 1.0;
  for (const CandidateRow& candidate : evaluation.configured.candidates) {
    highest = std::max(highest, candidate.score);
  }
  std::vector<double> grid;
  const int steps = std::max(2, evaluation_options.sweep_steps);
  for (int i = 0; i + 1 < steps; ++i) {
    grid.push_back(std::max(lowest, highest - (highest - lowest) * i / (steps - 1)));
  }
  grid.push_back(lowest);                 // Exactly: rounding must not take it below 0.
  std::map<double, DetectorPass> passes;  // By threshold.
  passes[options.acceptance.min_score] = evaluation.configured;
  const auto run = [&](double threshold) {
    if (passes.count(threshold)) return;
    DetectorPass pass = runPass(input, threshold, &evaluation, false, {});
    setRecall(&pass, evaluation.revisits);
    if (progress) progress(passes.size(), steps + evaluation_options.refine_steps + 1);
    passes[threshold] = std::move(pass);
  };
  for (const double threshold : grid) run(threshold);
  for (int i = 0; i < evaluation_options.refine_steps; ++i) {
    // Lowest clean threshold and the highest one below it that is not clean.
    double clean_threshold = highest;
    bool found_clean = false;
    for (auto it = passes.rbegin(); it != passes.rend(); ++it) {
      if (!clean(it->second)) break;
      clean_threshold = it->first;
      found_clean = true;
    }
    const auto below = passes.lower_bound(clean_threshold);
    if (!found_clean || below == passes.begin()) break;
    run(0.5 * (clean_threshold + std::prev(below)->first));
  }
  for (auto it = passes.rbegin(); it != passes.rend(); ++it) {
    if (it->first == options.acceptance.min_score) continue;
    evaluation.sweep.push_back(it->second);
  }
  for (const auto& [threshold, pass] : passes) {
    if (clean(pass) && pass.recall > evaluation.recall_at_100_precision) {
      evaluation.recall_at_100_precision = pass.recall;
      evaluation.threshold_at_100_precision = threshold;
    }
  }
  return evaluation;
}

std::string writeDetectorReport(const std::string& folder, const std::string& name,
                                const std::string& description, const DetectorEvaluation& result) {
  namespace fs = std::filesystem;
  fs::create_directories(folder);
  const fs::path base(folder);
  const std::string path = (base / ("detector_" + name + ".json")).string();
  DurableText json(path);
  json << std::setprecision(6);
  const auto write_pass = [&json](const DetectorPass& pass) {
    json << "{\"min_score\": " << pass.min_score << ", \"loops\": " << pass.loops.size()
         << ", \"true_loops\": " << pass.true_loops << ", \"precision\": " << pass.precision
         << ", \"recall\": " << pass.recall << ", \"refused\": {";
    bool first = true;
    for (const auto& [stage, count] : pass.refused) {
      json << (first ? "" : ", ") << "\"" << stage << "\": " << count;
      first = false;
    }
    json << "}}";
  };
  json << "{\n  \"name\": " << jsonString(name) << ",\n  \"setup\": " << jsonString(description)
       << ",\n  \"frames\": " << result.frames << ",\n  \"keyframes\": " << result.keyframes
       << ",\n  \"refused_frames\": " << result.refused_frames
       << ",\n  \"revisited_keyframes\": " << result.revisits
       << ",\n  \"recall_at_100_precision\": " << result.recall_at_100_precision
       << ",\n  \"threshold_at_100_precision\": " << result.threshold_at_100_precision
       << ",\n  \"keyframe_ms\": {\"median\": " << result.keyframe_ms.median
       << ", \"p99\": " << result.keyframe_ms.p99 << "},\n  \"configured\": ";
  write_pass(result.configured);
  json << ",\n  \"sweep\": [\n";
  for (size_t i = 0; i < result.sweep.size(); ++i) {
    json << "    ";
    write_pass(result.sweep[i]);
    json << (i + 1 < result.sweep.size() ? ",\n" : "\n");
  }
  json << "  ]\n}\n";
  json.commit();
  DurableText loops(base / ("loops_" + name + ".csv"));
  loops << "query_id,match_id,query_frame,match_frame,score,verified,correct\n"
        << std::setprecision(6);
  for (const PublishedLoop& loop : result.configured.loops) {
    loops << loop.query_id << "," << loop.match_id << "," << loop.query_frame << ","
          << loop.match_frame << "," << loop.score << "," << loop.verified << "," << loop.correct
          << "\n";
  }
  loops.commit();
  DurableText candidates(base / ("candidates_" + name + ".csv"));
  candidates << "query_id,match_id,query_frame,match_frame,global_score,score,verdict,correct,"
                "place_ratio,false_alarms,detail\n"
             << std::setprecision(6);
  for (const CandidateRow& row : result.configured.candidates) {
    candidates << row.query_id << "," << row.match_id << "," << row.query_frame << ","
               << row.match_frame << "," << row.global_score << "," << row.score << ","
               << row.verdict << "," << row.correct << "," << row.place_ratio << ","
               << row.false_alarms << "," << csvQuoted(row.detail) << "\n";
  }
  candidates.commit();
  return path;
}

}  // namespace eval
}  // namespace landmark_loop_closure
