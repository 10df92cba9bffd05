#include "landmark_loop_closure/runtime/detector_runtime.h"

#include "landmark_loop_closure/common/caught.h"

#include <algorithm>
#include <chrono>
#include <sstream>
#include <utility>

namespace landmark_loop_closure {

DetectorRuntime::DetectorRuntime(LoopDetector* detector, const RuntimeOptions& options,
                                 RuntimeListener listener)
    : detector_(detector),
      admission_(&detector->admission()),
      wants_colour_(detector->extractor()->wantsColour()),
      options_(options),
      listener_(std::move(listener)),
      queue_(options.queue_size) {
  worker_ = std::thread(&DetectorRuntime::work, this);
}

DetectorRuntime::~DetectorRuntime() { stop(); }

void DetectorRuntime::stop() {
  queue_.close();
  if (worker_.joinable()) worker_.join();
}

RuntimeAdmission DetectorRuntime::admit(FrameInput frame) {
  RuntimeAdmission result;
  if (options_.max_stamp_ahead_s > 0.0 && frame.clock > 0.0 &&
      frame.stamp > frame.clock + options_.max_stamp_ahead_s) {
    std::ostringstream message;
    message.precision(3);
    message << std::fixed << "stamp " << frame.stamp << " s is " << frame.stamp - frame.clock
            << " s ahead of the clock (" << frame.clock
            << " s); more than advanced/max_stamp_ahead_s " << options_.max_stamp_ahead_s;
    result.admission.error = InputError{InputErrorCode::kStampInFuture, message.str()};
    return result;
  }
  // Read before the detector admits the frame: a map replaced meanwhile drops this keyframe
  // rather than storing one admitted against the previous map.
  const uint64_t map_epoch = map_epoch_.load();
  if (restart_timeline_.exchange(false)) {
    admission_->restart();
    not_increasing_in_a_row_ = 0;
  }
  const auto admit_frame = [&] {
    return admission_->admit(frame.stamp, frame.pose, frame.width, frame.height, frame.cv_type,
                             frame.odometry_since);
  };
  result.admission = admit_frame();
  const bool not_increasing =
      result.admission.error && result.admission.error->code == InputErrorCode::kStampNotIncreasing;
  not_increasing_in_a_row_ = not_increasing ? not_increasing_in_a_row_ + 1 : 0;
  if (not_increasing) {
    const double back = admission_->lastKeyframeStamp().value_or(frame.stamp) - frame.stamp;
    const bool jumped_far =
        options_.time_jump_back == TimeJumpPolicy::kReset && back > options_.time_jump_back_s;
    const bool stuck =
        options_.time_jump_frames > 0 && not_increasing_in_a_row_ >= options_.time_jump_frames;
    if (jumped_far || stuck) {
      if (options_.time_jump_back == TimeJumpPolicy::kReset) {
        // The worker forgets the map when it takes the first keyframe of the new timeline, and
        // drops keyframes of the old one still queued.
        ++generation_;
        result.map_forgotten = true;
      }
      if (jumped_far) {
        result.timeline_restarted_after_s = back;
      } else {
        result.time_jump_after_frames_s = back;
        ++time_jumps_;
      }
      not_increasing_in_a_row_ = 0;
      admission_->restart();
      result.admission = admit_frame();
    }
  }
  if (!result.admission.isKeyframe()) return result;
  KeyframeJob job;
  job.id = result.admission.keyframe_id;
  job.stamp = frame.stamp;
  job.stamp_ns = frame.stamp_ns;
  job.pose = normalisedPose(frame.pose);  // Within tolerance of unit length once admitted.
  job.intrinsics = frame.intrinsics;
  job.source = std::move(frame.source);
  job.odometry_restarted = result.admission.selection.reanchored;
  job.generation = generation_.load();
  job.map_epoch = map_epoch;
  result.queued = true;
  result.dropped_oldest = queue_.push(std::move(job));
  if (result.dropped_oldest) ++dropped_;
  return result;
}

size_t DetectorRuntime::withDetector(const std::function<bool(LoopDetector&)>& action) {
  MutexLock lock(detector_mutex_);
  return runOnDetector(action);
}

bool DetectorRuntime::tryWithDetector(const std::function<bool(LoopDetector&)>& action) {
  if (!detector_mutex_.try_lock()) return false;
  MutexLock lock(detector_mutex_, std::adopt_lock);
  runOnDetector(action);
  return true;
}

DetectorRuntime::SaveOutcome DetectorRuntime::saveMap(const std::string& path, bool overwrite) {
  constexpr int kPagesPerStep = 2048;
  SaveOutcome outcome;
  withDetector([&](LoopDetector& detector) {
    outcome.target = path.empty() ? detector.map().path() : path;
    outcome.own_map = !outcome.target.empty() && outcome.target == detector.map().path();
    if (outcome.target.empty()) {
      outcome.error = "no path given and no map open (the parameter database_path is empty)";
    } else if (outcome.own_map) {
      outcome.error = detector.map().save(outcome.target, overwrite, &outcome.kept_as);
      if (outcome.error.empty()) outcome.error = detector.map().saveGraph();  // A checkpoint.
    } else {
      outcome.error = detector.map().beginSave(outcome.target, overwrite, &outcome.kept_as);
    }
    outcome.keyframes = detector.database().size();
    return false;
  });
  std::unique_ptr<MapCopy> copy;
  bool copied = outcome.own_map;
  while (outcome.error.empty() && !copied) {
    withDetector([&](LoopDetector& detector) {
      try {
        copied = detector.map().continueSave(kPagesPerStep);
        if (copied) copy = detector.map().takeSave();
      } catch (const std::exception& error) {
        outcome.error = error.what();
      }
      return false;
    });
    // The worker's turn: a mutex is not fair, and this thread would take it straight back.
    if (!copied) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (outcome.error.empty() && copy) {
    try {
      copy->finish();
      outcome.keyframes = copy->keyframes();
    } catch (const std::exception& error) {
      outcome.error = error.what();
    }
  }
  if (!outcome.error.empty() && !outcome.kept_as.empty()) {
    outcome.error += "; the earlier map is kept as " + outcome.kept_as;
  }
  return outcome;
}

size_t DetectorRuntime::runOnDetector(const std::function<bool(LoopDetector&)>& action) {
  if (!action(*detector_)) return 0;
  // The map was replaced: what was queued for the previous one is dropped.
  ++map_epoch_;
  return queue_.size();
}

void DetectorRuntime::work() {
  // An exception must not end the process (with a shared nodelet manager, the camera driver's
  // too): the job is dropped, counted and reported, and the next one is taken.
  while (std::optional<KeyframeJob> job = queue_.pop()) {
    const std::optional<std::string> what = runCaught([&] { process(*job); });
    if (!what) continue;
    ++failed_;
    if (listener_.failed) reportCaught([&] { listener_.failed(*job, *what); });
  }
}

void DetectorRuntime::process(KeyframeJob& job) {
  const auto start = std::chrono::steady_clock::now();
  const auto dropped = [&] {
    if (job.generation < generation_.load()) {  // From before time jumped back.
      ++stale_;
      return true;
    }
    if (job.map_epoch < map_epoch_.load()) {  // Queued before a load or reset replaced the map.
      ++dropped_at_map_switch_;
      return true;
    }
    return false;
  };
  if (dropped()) return;
  // The images are prepared with the detector free, so a depth wait (bounded, 0.2 s) or an image
  // conversion never holds a service back.
  PreparedKeyframe prepared;
  InputError error{InputErrorCode::kUnsupportedImageType, "the frame could not be prepared"};
  const bool ready = !listener_.prepare || listener_.prepare(job, wants_colour_, &prepared, &error);
  MutexLock lock(detector_mutex_);
  if (dropped()) return;  // A service switched maps while the images were prepared.
  if (job.generation > worker_generation_) {
    worker_generation_ = job.generation;
    detector_->map().reset();
    if (listener_.timeline_reset) listener_.timeline_reset();
  }
  const auto reject = [this](const InputError& error) {
    if (listener_.rejected) listener_.rejected(error);
  };
  // Marked even when this keyframe is refused: the next one then starts the new session.
  if (job.odometry_restarted) detector_->markOdometryRestart(job.id);
  if (prepared.camera_mount) detector_->setCameraMount(*prepared.camera_mount);
  if (!ready) {
    reject(error);
    return;
  }
  const KeyframeResult result = detector_->addKeyframe(
      job.id, job.stamp, job.pose, prepared.image, job.intrinsics, prepared.depth, job.stamp_ns);
  if (result.error) {
    reject(*result.error);
    return;
  }
  if (listener_.keyframe) listener_.keyframe(job, result, prepared);
  const double elapsed =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  last_ms_ = elapsed;
  max_ms_ = std::max(max_ms_.load(), elapsed);
}

}  // namespace landmark_loop_closure
