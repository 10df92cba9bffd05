#include "landmark_loop_closure/backend/pose_graph_runtime.h"

#include <cstdio>
#include <filesystem>

#include "landmark_loop_closure/backend/pose_graph_file.h"
#include "landmark_loop_closure/common/caught.h"

namespace landmark_loop_closure {

PoseGraphRuntime::PoseGraphRuntime(PoseGraphNodeOptions options, MountLookup mount,
                                   PoseGraphListener listener, std::chrono::milliseconds catch_up)
    : session_(options, std::move(mount)),
      listener_(std::move(listener)),
      catch_up_(catch_up),
      graph_file_(options.graph_file),
      last_save_(std::chrono::steady_clock::now()) {
  worker_ = std::thread([this] { work(); });
}

PoseGraphRuntime::~PoseGraphRuntime() { stop(); }

void PoseGraphRuntime::push(PoseGraphSession::Input input) {
  {
    MutexLock lock(mutex_);
    inputs_.push_back(std::move(input));
  }
  wake_.notify_one();
}

std::optional<GraphCorrection> PoseGraphRuntime::correction() const {
  MutexLock lock(correction_mutex_);
  return correction_;
}

std::vector<GraphCorrection> PoseGraphRuntime::corrections() const {
  MutexLock lock(correction_mutex_);
  return corrections_;
}

void PoseGraphRuntime::stop() {
  {
    MutexLock lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (!worker_.joinable()) return;
  worker_.join();
  reportCaught([&] { save(); });
}

void PoseGraphRuntime::tell(const std::string& text, bool problem) {
  if (listener_.graph_file) reportCaught([&] { listener_.graph_file(text, problem); });
}

void PoseGraphRuntime::restore() {
  if (graph_file_.empty()) return;
  std::error_code error;
  if (!std::filesystem::exists(graph_file_, error)) {
    tell("no saved graph at " + graph_file_ + " yet: the graph starts empty", false);
    return;
  }
  std::vector<PoseGraphSession::Input> inputs;
  const std::string problem = readGraphFile(graph_file_, &inputs);
  if (!problem.empty()) {
    graph_file_refused_ = true;
    tell("the saved graph " + graph_file_ + " cannot be used (" + problem +
             "): the graph starts empty, and that file is left as it is, never written",
         true);
    return;
  }
  const auto start = std::chrono::steady_clock::now();
  publish(session_.restore(inputs));
  saved_revision_ = session_.keptRevision();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  char text[320];
  std::snprintf(text, sizeof(text),
                "restored %zu keyframes in %zu chain(s) (%zu joined to the first) and %zu loops "
                "from %s in %.2f s",
                session_.graph().keyframes(), session_.graph().chains(),
                session_.graph().chainsJoinedToFirst(), session_.graph().loops(),
                graph_file_.c_str(), seconds);
  tell(text, false);
}

void PoseGraphRuntime::save() {
  if (graph_file_.empty() || graph_file_refused_ || session_.keptRevision() == saved_revision_) {
    return;
  }
  last_save_ = std::chrono::steady_clock::now();
  const std::string problem = saveGraphFile(graph_file_, session_.kept());
  if (!problem.empty()) {
    tell("the graph could not be saved to " + graph_file_ + ": " + problem, true);
    return;
  }
  saved_revision_ = session_.keptRevision();
}

std::string PoseGraphRuntime::summary() const { return session_.summary(); }

void PoseGraphRuntime::work() {
  if (const std::optional<std::string> what = runCaught([&] { restore(); })) {
    graph_file_refused_ = true;
    tell("the saved graph " + graph_file_ + " could not be restored (" + *what +
             "): that file is left as it is, never written",
         true);
  }
  for (;;) {
    std::vector<PoseGraphSession::Input> batch;
    bool woken = false;
    {
      MutexLock lock(mutex_);
      const auto give_up = std::chrono::steady_clock::now() + catch_up_;
      while (!stopping_ && inputs_.empty() && lock.waitUntil(wake_, give_up)) {
      }
      woken = stopping_ || !inputs_.empty();
      if (stopping_) return;
      batch.swap(inputs_);
    }
    // An exception must not end the process (with a shared nodelet manager, the detector and
    // the camera driver too): counted, reported, and the worker takes the next batch.
    const std::optional<std::string> what = runCaught([&] {
      if (woken) {
        process(batch);
      } else if (session_.pathsBehind() && listener_.catch_up) {
        listener_.catch_up(session_);
      }
      // A crash loses at most the last few seconds of the graph.
      if (std::chrono::steady_clock::now() - last_save_ >= kSaveInterval) save();
    });
    if (!what) continue;
    ++failures_;
    if (listener_.failed) reportCaught([&] { listener_.failed(*what); });
  }
}

void PoseGraphRuntime::process(const std::vector<PoseGraphSession::Input>& batch) {
  publish(session_.process(batch));
}

void PoseGraphRuntime::publish(const GraphStep& step) {
  if (step.changed && !session_.odometryFrame().empty()) {
    std::vector<GraphCorrection> corrections;
    for (const auto& [frame, correction] : session_.corrections()) {
      corrections.push_back({correction, frame});
    }
    MutexLock lock(correction_mutex_);
    correction_ = GraphCorrection{session_.graph().mapFromOdometry(), session_.odometryFrame()};
    corrections_ = std::move(corrections);
  }
  if (listener_.step) listener_.step(session_, step);
}

}  // namespace landmark_loop_closure
