#pragma once

#include <cstddef>
#include <deque>
#include <vector>

namespace landmark_loop_closure {

/// Per-condition standardisation of global descriptors (Schubert, Neubert and Protzel, ICRA 2020),
/// run online: each keyframe's global vector loses the mean of the camera's last `window`
/// keyframes (itself included) and is normalised again. What those keyframes share - the light,
/// the weather, the season, the camera's own look - goes; what makes the place differ from its
/// neighbours stays. Two dark night frames of different places then no longer look alike merely
/// for being dark, while the same place seen by day and by night keeps what it has in common.
/// Keyframes searched and stored are the standardised vectors, so the database compares like with
/// like. Not thread-safe: the detector's worker owns it.
class ConditionStandardiser {
 public:
  /// `window`: keyframes averaged; 0 = off (vectors pass unchanged).
  explicit ConditionStandardiser(int window = 0);

  bool enabled() const { return window_ > 0; }
  /// Keyframes in the window now.
  size_t held() const { return recent_.size(); }

  /// Adds `global` to the window and returns it standardised (L2-normalised). While the window
  /// holds `global` alone, or when it equals the window's mean, there is nothing to tell it apart
  /// by: zeros are returned, which match nothing (a session's first keyframe is never a loop's
  /// match). A vector of another length than the window's restarts the window (the descriptor
  /// changed). Non-finite values count as 0.
  std::vector<float> apply(const std::vector<float>& global);

  /// The window holds fewer than `window` keyframes (a start): what apply() returned leaned on
  /// those few alone.
  bool warmingUp() const { return enabled() && recent_.size() < static_cast<size_t>(window_); }

  /// `global` standardised against the window as it is now, without adding it (for a keyframe
  /// that came while the window was warming up); zeros under the same rules as apply().
  std::vector<float> standardise(const std::vector<float>& global) const;

 private:
  void reset();

  int window_;
  std::deque<std::vector<float>> recent_;
  std::vector<double> sum_;  ///< Of the vectors in recent_.
};

}  // namespace landmark_loop_closure
