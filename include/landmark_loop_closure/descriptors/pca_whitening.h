#pragma once

#include <stdexcept>
#include <string>

#include <Eigen/Core>

namespace landmark_loop_closure {

/// A whitening file that cannot be used: missing, truncated, corrupt, or made for other features.
class WhiteningFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// PCA followed by whitening (methods.md section 2): centre on the training mean, project on the
/// `components` eigenvectors of the covariance with the largest eigenvalues, divide each
/// component by the square root of its eigenvalue. Whitened training data has unit covariance.
class PcaWhitening {
 public:
  /// `samples`: one feature vector per row (N x D). Keeps min(components, N - 1, D) components.
  /// `regularisation`: added to every eigenvalue before the square root, as a fraction of the
  /// largest, so directions with almost no variance are not blown up into noise.
  /// Throws std::invalid_argument for fewer than 2 samples, components < 1 or non-finite values.
  static PcaWhitening fit(const Eigen::MatrixXf& samples, int components,
                          double regularisation = 0.0);

  int inputDimension() const { return static_cast<int>(mean_.size()); }
  int outputDimension() const { return static_cast<int>(eigenvalues_.size()); }
  bool empty() const { return eigenvalues_.size() == 0; }

  /// Whitened, not normalised: `input` has inputDimension() values.
  Eigen::VectorXf apply(const Eigen::Ref<const Eigen::VectorXf>& input) const;

  const Eigen::VectorXf& mean() const { return mean_; }
  /// Largest first.
  const Eigen::VectorXf& eigenvalues() const { return eigenvalues_; }
  /// One unit eigenvector per row, in the order of eigenvalues().
  const Eigen::MatrixXf& components() const { return components_; }
  double regularisation() const { return regularisation_; }
  /// Fraction of the training variance the kept components explain.
  double explainedVariance() const { return explained_variance_; }

  /// Little-endian binary file with a checksum; `identity` says which features it was fitted on
  /// (model, layer, input) and is checked by load().
  void save(const std::string& path, const std::string& identity) const;
  /// Throws WhiteningFileError naming the file and what is wrong, including an identity other
  /// than `expected_identity` (pass an empty string to accept any).
  static PcaWhitening load(const std::string& path, const std::string& expected_identity);

 private:
  Eigen::VectorXf mean_;
  Eigen::VectorXf eigenvalues_;
  Eigen::MatrixXf components_;
  Eigen::MatrixXf projection_;  // components_ rows divided by sqrt(eigenvalue + regulariser).
  double regularisation_ = 0.0;
  double explained_variance_ = 0.0;

  void updateProjection();
};

}  // namespace landmark_loop_closure
