// lcd_bench_save: a map saved while frames stream, as the node's ~save_database runs beside its
// worker. The map at --map (made by `lcd_bench_map --identity detector`, or a node's) is opened
// by a detector with the shipped settings; the generated corridor's frames are admitted at
// --rate Hz through the node's runtime (queue, worker thread); after --warmup seconds the map is
// copied to --copy through DetectorRuntime::saveMap, and frames go on --after seconds past its
// end. Prints the save's time and, before and during it, each keyframe's worker time and its
// latency (admitted to done) as median / p99 / max, and the keyframes dropped.
// --whole 1 saves as the node did before saves went in steps (the detector held throughout).
//   lcd_bench_save --map MAP --copy NEW_PATH [--rate 10] [--warmup 10] [--after 5] [--whole 1]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <future>
#include <iostream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "command_line.h"
#include "landmark_loop_closure/descriptors/registry.h"
#include "landmark_loop_closure/eval/metrics.h"
#include "landmark_loop_closure/runtime/detector_runtime.h"
#include "landmark_loop_closure/sim/corridor_world.h"
#include "landmark_loop_closure/sim/sequence.h"

namespace {

using namespace landmark_loop_closure;
using Clock = std::chrono::steady_clock;

struct Settings {
  std::string map;
  std::string copy;
  double rate_hz = 10.0;
  double warmup_s = 10.0;
  double after_s = 5.0;
  /// --whole: the save as it ran before steps, one hold of the detector for the whole copy.
  bool whole = false;
};

// A frame's image and when it was admitted, carried through the runtime as the job's source.
struct StreamedFrame {
  cv::Mat image;
  Clock::time_point admitted;
};

// One keyframe done by the worker: when, its worker time and its latency from admission.
struct Done {
  Clock::time_point at;
  double worker_ms = 0.0;
  double latency_ms = 0.0;
};

void printWindow(const char* name, const std::vector<Done>& done, Clock::time_point from,
                 Clock::time_point to) {
  std::vector<double> worker, latency;
  for (const Done& keyframe : done) {
    if (keyframe.at < from || keyframe.at >= to) continue;
    worker.push_back(keyframe.worker_ms);
    latency.push_back(keyframe.latency_ms);
  }
  const auto largest = [](const std::vector<double>& values) {
    return values.empty() ? 0.0 : *std::max_element(values.begin(), values.end());
  };
  const eval::Percentiles worker_ms = eval::percentiles(worker);
  const eval::Percentiles latency_ms = eval::percentiles(latency);
  std::printf("| %s | %zu | %.1f / %.1f / %.1f | %.1f / %.1f / %.1f |\n", name, worker.size(),
              worker_ms.median, worker_ms.p99, largest(worker), latency_ms.median, latency_ms.p99,
              largest(latency));
}

}  // namespace

int main(int argc, char** argv) {
  Settings settings;
  int whole = 0;
  CLI::App app{
      "A map saved in steps under a stream of keyframes: the worker's time and each keyframe's "
      "latency before, during and after the save."};
  app.add_option("--map", settings.map, "the map to open")->required();
  app.add_option("--copy", settings.copy, "a new file for the saved copy")->required();
  app.add_option("--rate", settings.rate_hz, "keyframes a second")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--warmup", settings.warmup_s, "seconds streamed before the save")
      ->capture_default_str();
  app.add_option("--after", settings.after_s, "seconds streamed after it")->capture_default_str();
  app.add_option("--whole", whole,
                 "1: the save as it ran before steps, one hold of the detector for the whole copy")
      ->check(CLI::IsMember({0, 1}))
      ->capture_default_str();
  if (const auto exit_code = tools::parseCommandLine(&app, argc, argv)) return *exit_code;
  settings.whole = whole == 1;
  if (std::filesystem::exists(settings.copy)) {
    std::cerr << settings.copy << " exists: name a new file for the copy\n";
    return 2;
  }
  const LoopDetectorOptions options;
  LoopDetector detector(options, makeDescriptorExtractor(options.descriptor));
  const auto open_start = Clock::now();
  const std::string open_error = detector.map().open(settings.map);
  if (!open_error.empty()) {
    std::cerr << open_error << "\n";
    return 1;
  }
  std::printf("Map %s: %zu keyframes opened in %.2f s\n", settings.map.c_str(),
              detector.database().size(),
              std::chrono::duration<double>(Clock::now() - open_start).count());

  std::mutex mutex;
  std::vector<Done> done;
  RuntimeListener listener;
  listener.prepare = [](const KeyframeJob& job, bool, PreparedKeyframe* prepared, InputError*) {
    const auto& frame = std::any_cast<const StreamedFrame&>(job.source);
    prepared->image = frame.image;
    prepared->grey = frame.image;
    return true;
  };
  listener.keyframe = [&](const KeyframeJob& job, const KeyframeResult& result,
                          const PreparedKeyframe&) {
    const Clock::time_point now = Clock::now();
    const auto& frame = std::any_cast<const StreamedFrame&>(job.source);
    const std::lock_guard<std::mutex> lock(mutex);
    done.push_back({now, result.times.totalMs(),
                    std::chrono::duration<double, std::milli>(now - frame.admitted).count()});
  };
  DetectorRuntime runtime(&detector, RuntimeOptions{}, listener);

  const sim::CorridorWorld world;
  const sim::CameraModel camera;
  sim::SequenceOptions sequence_options;
  sequence_options.laps = 20.0;
  sim::SequenceGenerator sequence(world, camera, sequence_options);
  const auto period = std::chrono::duration<double>(1.0 / settings.rate_hz);
  const Clock::time_point start = Clock::now();
  std::future<DetectorRuntime::SaveOutcome> save;
  Clock::time_point save_start, save_end;
  size_t frames = 0, keyframes = 0;
  sim::SequenceFrame frame;
  while (sequence.next(&frame)) {
    const Clock::time_point now = Clock::now();
    if (!save.valid() && now - start >= std::chrono::duration<double>(settings.warmup_s)) {
      save_start = now;
      save = std::async(std::launch::async, [&] {
        if (!settings.whole) return runtime.saveMap(settings.copy, /*overwrite=*/false);
        DetectorRuntime::SaveOutcome outcome;
        outcome.target = settings.copy;
        runtime.withDetector([&](LoopDetector& held) {
          outcome.error = held.map().save(settings.copy);
          outcome.keyframes = held.database().size();
          return false;
        });
        return outcome;
      });
    }
    if (save.valid() && save_end == Clock::time_point() &&
        save.wait_for(std::chrono::seconds(0)) == std::future_status::ready) {
      save_end = now;
    }
    if (save_end != Clock::time_point() &&
        now - save_end >= std::chrono::duration<double>(settings.after_s)) {
      break;
    }
    FrameInput input;
    input.stamp = frame.stamp;
    input.pose = planarPose(frame.odom.x, frame.odom.y, frame.odom.yaw);
    input.width = frame.image.cols;
    input.height = frame.image.rows;
    input.cv_type = frame.image.type();
    input.intrinsics = camera.intrinsics();
    input.source = StreamedFrame{frame.image, now};
    keyframes += runtime.admit(std::move(input)).queued ? 1 : 0;
    ++frames;
    std::this_thread::sleep_until(
        start + std::chrono::duration_cast<Clock::duration>(period * static_cast<double>(frames)));
  }
  if (!save.valid()) {
    std::cerr << "the corridor ended before the save started\n";
    return 1;
  }
  const DetectorRuntime::SaveOutcome saved = save.get();
  if (save_end == Clock::time_point()) save_end = Clock::now();
  runtime.stop();
  std::printf("%zu frames at %.0f Hz, %zu keyframes queued, %lu dropped (queue full)\n", frames,
              settings.rate_hz, keyframes, static_cast<unsigned long>(runtime.keyframesDropped()));
  std::printf("Save: %s in %.2f s (%zu keyframes)\n",
              saved.error.empty() ? ("copied to " + saved.target).c_str() : saved.error.c_str(),
              std::chrono::duration<double>(save_end - save_start).count(), saved.keyframes);
  const std::lock_guard<std::mutex> lock(mutex);
  std::printf(
      "\n| window | keyframes | worker ms median / p99 / max | latency ms median / p99 / max |\n"
      "|---|---|---|---|\n");
  printWindow("before the save", done, start, save_start);
  printWindow("during the save", done, save_start, save_end);
  printWindow("after it", done, save_end, Clock::now());
  return saved.error.empty() ? 0 : 1;
}
