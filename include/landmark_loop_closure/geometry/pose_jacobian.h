#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

namespace landmark_loop_closure {

/// The package's one order for pose increments, covariances and Jacobian columns: translation
/// first, then rotation (x, y, z; rotation vector about x, y, z applied on the left), the order
/// of LoopClosure.relative_pose's covariance. A scale-free pose's translation has two
/// parameters (steps in the tangent plane of its direction), then the same three of rotation.
///
/// Central-difference Jacobian of `residuals` (a function of the increment, zero = the current
/// estimate) at zero: one column per entry of `columns`, each the derivative by that parameter
/// of a `parameters`-long increment (columns left out are held at zero).
Eigen::MatrixXd poseJacobian(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& residuals, int parameters,
    const std::vector<int>& columns, double step = 1e-6);

/// Every column, in order.
std::vector<int> allColumns(int parameters);

}  // namespace landmark_loop_closure
