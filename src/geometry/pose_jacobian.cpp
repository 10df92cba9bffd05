#include "landmark_loop_closure/geometry/pose_jacobian.h"

#include <numeric>

namespace landmark_loop_closure {

Eigen::MatrixXd poseJacobian(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& residuals, int parameters,
    const std::vector<int>& columns, double step) {
  Eigen::MatrixXd jacobian;
  for (size_t c = 0; c < columns.size(); ++c) {
    Eigen::VectorXd plus = Eigen::VectorXd::Zero(parameters);
    Eigen::VectorXd minus = Eigen::VectorXd::Zero(parameters);
    plus(columns[c]) = step;
    minus(columns[c]) = -step;
    const Eigen::VectorXd derivative = (residuals(plus) - residuals(minus)) / (2.0 * step);
    if (c == 0) jacobian.resize(derivative.size(), static_cast<Eigen::Index>(columns.size()));
    jacobian.col(static_cast<Eigen::Index>(c)) = derivative;
  }
  return jacobian;
}

std::vector<int> allColumns(int parameters) {
  std::vector<int> columns(static_cast<size_t>(parameters));
  std::iota(columns.begin(), columns.end(), 0);
  return columns;
}

}  // namespace landmark_loop_closure
