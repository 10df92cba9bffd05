#include "landmark_loop_closure/descriptors/pca_whitening.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

#include "common/checksummed_file.h"

namespace landmark_loop_closure {

namespace {

constexpr char kMagic[8] = {'L', 'L', 'C', 'W', 'H', 'I', 'T', 'E'};
constexpr uint32_t kVersion = 1;
constexpr uint32_t kMaxDimension = 1u << 20;

}  // namespace

PcaWhitening PcaWhitening::fit(const Eigen::MatrixXf& samples, int components,
                               double regularisation) {
  const Eigen::Index n = samples.rows();
  const Eigen::Index d = samples.cols();
  if (n < 2 || d < 1) throw std::invalid_argument("PCA needs at least 2 samples of 1 value");
  if (components < 1) throw std::invalid_argument("PCA needs at least 1 component");
  if (!samples.allFinite()) throw std::invalid_argument("PCA samples hold NaN or infinity");
  if (!(regularisation >= 0.0)) throw std::invalid_argument("regularisation must be >= 0");

  const Eigen::MatrixXd data = samples.cast<double>();
  const Eigen::RowVectorXd mean = data.colwise().mean();
  const Eigen::MatrixXd centred = data.rowwise() - mean;
  const Eigen::Index kept = std::min<Eigen::Index>({components, n - 1, d});

  // Eigenvectors of the D x D covariance, or, with fewer samples than values, of the N x N Gram
  // matrix mapped back (the same non-zero eigenvalues at a fraction of the cost).
  Eigen::VectorXd values;
  Eigen::MatrixXd vectors;  // D x kept, unit columns, largest eigenvalue first.
  double total_variance = 0.0;
  if (d <= n) {
    const Eigen::MatrixXd covariance = centred.transpose() * centred / static_cast<double>(n - 1);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(covariance);
    values = solver.eigenvalues().reverse().head(kept);
    vectors = solver.eigenvectors().rowwise().reverse().leftCols(kept);
    total_variance = covariance.trace();
  } else {
    const Eigen::MatrixXd gram = centred * centred.transpose() / static_cast<double>(n - 1);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(gram);
    values = solver.eigenvalues().reverse().head(kept);
    const Eigen::MatrixXd gram_vectors = solver.eigenvectors().rowwise().reverse().leftCols(kept);
    vectors = centred.transpose() * gram_vectors;
    for (Eigen::Index k = 0; k < kept; ++k) {
      const double norm = vectors.col(k).norm();
      if (norm > 0.0) vectors.col(k) /= norm;
    }
    total_variance = gram.trace();
  }
  values = values.cwiseMax(0.0);  // Round-off can leave -1e-17 where the true value is 0.

  PcaWhitening whitening;
  whitening.mean_ = mean.transpose().cast<float>();
  whitening.eigenvalues_ = values.cast<float>();
  whitening.components_ = vectors.transpose().cast<float>();
  whitening.regularisation_ = regularisation;
  whitening.explained_variance_ = total_variance > 0.0 ? values.sum() / total_variance : 0.0;
  whitening.updateProjection();
  return whitening;
}

void PcaWhitening::updateProjection() {
  const double largest = eigenvalues_.size() > 0 ? eigenvalues_(0) : 0.0;
  // A floor keeps a direction of exactly zero variance from dividing by zero.
  const double added = std::max(regularisation_ * largest, 1e-12);
  projection_ = components_;
  for (Eigen::Index k = 0; k < projection_.rows(); ++k) {
    projection_.row(k) /= static_cast<float>(std::sqrt(eigenvalues_(k) + added));
  }
}

Eigen::VectorXf PcaWhitening::apply(const Eigen::Ref<const Eigen::VectorXf>& input) const {
  if (input.size() != mean_.size()) {
    throw std::invalid_argument("whitening expects " + std::to_string(mean_.size()) +
                                " values, got " + std::to_string(input.size()));
  }
  return projection_ * (input - mean_);
}

void PcaWhitening::save(const std::string& path, const std::string& identity) const {
  LittleEndianWriter writer;
  beginChecksummedFile(&writer, kMagic, kVersion);
  writer.u32(static_cast<uint32_t>(inputDimension()));
  writer.u32(static_cast<uint32_t>(outputDimension()));
  writer.f64(regularisation_);
  writer.f64(explained_variance_);
  writer.text(identity);
  writer.floats(mean_.data(), mean_.size());
  writer.floats(eigenvalues_.data(), eigenvalues_.size());
  const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows = components_;
  writer.floats(rows.data(), rows.size());
  const std::string error = finishChecksummedFile(path, &writer);
  if (!error.empty()) throw WhiteningFileError("whitening file " + path + ": " + error);
}

PcaWhitening PcaWhitening::load(const std::string& path, const std::string& expected_identity) {
  const auto fail = [&path](const std::string& what) {
    return WhiteningFileError("whitening file " + path + ": " + what);
  };
  std::vector<uint8_t> body;
  const std::string error = readChecksummedFile(path, kMagic, kVersion, "whitening", &body);
  if (!error.empty()) throw fail(error);
  LittleEndianReader reader(body.data(), body.size());
  uint32_t input = 0, output = 0;
  PcaWhitening whitening;
  std::string identity;
  bool ok = reader.u32(&input) && reader.u32(&output) && input > 0 && output > 0 &&
            input <= kMaxDimension && output <= input;
  ok = ok && reader.f64(&whitening.regularisation_) && reader.f64(&whitening.explained_variance_) &&
       reader.text(&identity);
  if (!ok) throw fail("header is damaged");
  if (!expected_identity.empty() && identity != expected_identity) {
    throw fail("made for other features (" + identity + "), not " + expected_identity);
  }
  whitening.mean_.resize(input);
  whitening.eigenvalues_.resize(output);
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows(output, input);
  ok = reader.floats(whitening.mean_.data(), input) &&
       reader.floats(whitening.eigenvalues_.data(), output) &&
       reader.floats(rows.data(), rows.size()) && reader.remaining() == 0;
  if (!ok) throw fail("size does not match its header");
  if (!whitening.mean_.allFinite() || !whitening.eigenvalues_.allFinite() || !rows.allFinite() ||
      (whitening.eigenvalues_.array() < 0.0f).any() || !(whitening.regularisation_ >= 0.0)) {
    throw fail("holds NaN, infinity or negative eigenvalues");
  }
  whitening.components_ = rows;
  whitening.updateProjection();
  return whitening;
}

}  // namespace landmark_loop_closure
