// When a loop closure is right on a route whose true positions are known: the one rule the demo
// report, lcd_evaluate --detector, the benchmarks and the tests all judge loops by.
#pragma once

#include <string>

#include <Eigen/Core>

namespace landmark_loop_closure {
namespace eval {

struct TrueLoopRule {
  double max_distance_m = 2.5;  ///< The two keyframes' true positions at most this far apart...
  double min_gap_s = 20.0;      ///< ...and their stamps at least this far apart (a revisit).

  bool isTrueLoop(const Eigen::Vector3d& query, double query_stamp, const Eigen::Vector3d& match,
                  double match_stamp) const;
  /// "within 2.5 m, 20 s apart"
  std::string describe() const;
};

}  // namespace eval
}  // namespace landmark_loop_closure
