#include "landmark_loop_closure/eval/true_loop.h"

#include <cmath>
#include <cstdio>

namespace landmark_loop_closure {
namespace eval {

bool TrueLoopRule::isTrueLoop(const Eigen::Vector3d& query, double query_stamp,
                              const Eigen::Vector3d& match, double match_stamp) const {
  return (query - match).norm() <= max_distance_m &&
         std::abs(query_stamp - match_stamp) >= min_gap_s;
}

std::string TrueLoopRule::describe() const {
  char text[64];
  std::snprintf(text, sizeof(text), "within %.1f m, %.0f s apart", max_distance_m, min_gap_s);
  return text;
}

}  // namespace eval
}  // namespace landmark_loop_closure
