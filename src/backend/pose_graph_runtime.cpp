#include "landmark_loop_closure/backend/pose_graph_runtime.h"

#include "landmark_loop_closure/common/caught.h"

namespace landmark_loop_closure {

PoseGraphRuntime::PoseGraphRuntime(PoseGraphNodeOptions options, MountLookup mount,
                                   PoseGraphListener listener, std::chrono::milliseconds catch_up)
    : session_(std::move(options), std::move(mount)),
      listener_(std::move(listener)),
      catch_up_(catch_up) {
  worker_ = std::thread([this] { work(); });
}

PoseGraphRuntime::~PoseGraphRuntime() { stop(); }

void PoseGraphRuntime::push(PoseGraphSession::Input input) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    inputs_.push_back(std::move(input));
  }
  wake_.notify_one();
}

std::optional<GraphCorrection> PoseGraphRuntime::correction() const {
  std::lock_guard<std::mutex> lock(correction_mutex_);
  return correction_;
}

void PoseGraphRuntime::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
}

std::string PoseGraphRuntime::summary() const { return session_.summary(); }

void PoseGraphRuntime::work() {
  for (;;) {
    std::vector<PoseGraphSession::Input> batch;
    bool woken = false;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      woken = wake_.wait_for(lock, catch_up_, [this] { return stopping_ || !inputs_.empty(); });
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
    });
    if (!what) continue;
    ++failures_;
    if (listener_.failed) reportCaught([&] { listener_.failed(*what); });
  }
}

void PoseGraphRuntime::process(const std::vector<PoseGraphSession::Input>& batch) {
  const GraphStep step = session_.process(batch);
  if (step.changed && !session_.odometryFrame().empty()) {
    std::lock_guard<std::mutex> lock(correction_mutex_);
    correction_ = GraphCorrection{session_.graph().mapFromOdometry(), session_.odometryFrame()};
  }
  if (listener_.step) listener_.step(session_, step);
}

}  // namespace landmark_loop_closure
