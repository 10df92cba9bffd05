#include "landmark_loop_closure/eval/ground_truth.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace landmark_loop_closure {
namespace eval {

GroundTruth::GroundTruth(size_t rows, size_t cols) : rows_(rows), cols_(cols), positives_(rows) {}

void GroundTruth::add(size_t row, size_t col) {
  if (row >= rows_ || col >= cols_) {
    throw GroundTruthError("ground-truth entry (" + std::to_string(row) + ", " +
                           std::to_string(col) + ") outside " + std::to_string(rows_) + " x " +
                           std::to_string(cols_));
  }
  positives_[row].push_back(static_cast<uint32_t>(col));
}

void GroundTruth::finalize() {
  for (auto& row : positives_) {
    std::sort(row.begin(), row.end());
    row.erase(std::unique(row.begin(), row.end()), row.end());
  }
}

void requirePositives(const GroundTruth& truth, const std::string& source) {
  if (truth.count() > 0) return;
  throw GroundTruthError("the ground truth (" + source + ", " + std::to_string(truth.rows()) +
                         " x " + std::to_string(truth.cols()) +
                         ") marks no pair of images as the same place, so every measure would "
                         "read 0; check the file (and --gt-var), or give --no-ground-truth to "
                         "look at the matches without one");
}

size_t GroundTruth::count() const {
  size_t total = 0;
  for (const auto& row : positives_) total += row.size();
  return total;
}

bool GroundTruth::contains(size_t row, size_t col) const {
  if (row >= rows_) return false;
  const auto& list = positives_[row];
  return std::binary_search(list.begin(), list.end(), static_cast<uint32_t>(col));
}

size_t GroundTruth::rowsWithPositives() const {
  return static_cast<size_t>(std::count_if(positives_.begin(), positives_.end(),
                                           [](const auto& row) { return !row.empty(); }));
}

GroundTruth::Shape GroundTruth::shape() const {
  bool lower = false;
  bool upper = false;
  bool symmetric = rows_ == cols_;
  bool any = false;
  for (size_t row = 0; row < rows_; ++row) {
    for (const uint32_t col : positives_[row]) {
      any = true;
      lower |= row > col;
      upper |= row < col;
      if (symmetric && !contains(col, row)) symmetric = false;
    }
  }
  if (!any) return Shape::kEmpty;
  if (symmetric) return Shape::kSymmetric;
  if (lower && !upper) return Shape::kLowerTriangular;
  if (upper && !lower) return Shape::kUpperTriangular;
  return Shape::kMixed;
}

GroundTruth GroundTruth::undirected() const {
  if (rows_ != cols_) throw GroundTruthError("undirected() needs a square ground truth");
  GroundTruth result(rows_, cols_);
  for (size_t row = 0; row < rows_; ++row) {
    for (const uint32_t col : positives_[row]) {
      result.add(row, col);
      result.add(col, row);
    }
  }
  result.finalize();
  return result;
}

const char* toString(GroundTruth::Shape shape) {
  switch (shape) {
    case GroundTruth::Shape::kEmpty:
      return "empty";
    case GroundTruth::Shape::kSymmetric:
      return "symmetric";
    case GroundTruth::Shape::kLowerTriangular:
      return "lower_triangular";
    case GroundTruth::Shape::kUpperTriangular:
      return "upper_triangular";
    case GroundTruth::Shape::kMixed:
      return "mixed";
  }
  return "unknown";
}

GroundTruth alignedGroundTruth(size_t queries, size_t database, int tolerance,
                               const std::vector<bool>& stopped) {
  // place[i]: moving frames up to frame i; a stop keeps the place of the frame before it.
  const size_t frames = std::max(queries, database);
  std::vector<long> place(frames);
  for (size_t i = 0; i < frames; ++i) {
    const bool stop = i > 0 && i < stopped.size() && stopped[i];
    place[i] = i == 0 ? 0 : place[i - 1] + (stop ? 0 : 1);
  }
  GroundTruth truth(queries, database);
  for (size_t query = 0; query < queries; ++query) {
    // Places only grow with the frame index: walk out from the query's own frame both ways.
    for (long match = std::min<long>(query, static_cast<long>(database) - 1);
         match >= 0 && place[query] - place[match] <= tolerance; --match) {
      truth.add(query, static_cast<size_t>(match));
    }
    for (size_t match = query + 1; match < database && place[match] - place[query] <= tolerance;
         ++match) {
      truth.add(query, match);
    }
  }
  truth.finalize();
  return truth;
}

GroundTruth poseGroundTruth(const std::vector<Pose>& poses, const std::vector<double>& stamps,
                            double max_distance, double max_angle, double min_time_gap) {
  if (stamps.size() != poses.size()) {
    throw GroundTruthError("poses (" + std::to_string(poses.size()) + ") and stamps (" +
                           std::to_string(stamps.size()) + ") differ in number");
  }
  const size_t n = poses.size();
  GroundTruth truth(n, n);
  const double max_distance_squared = max_distance * max_distance;
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (std::abs(stamps[i] - stamps[j]) < min_time_gap) continue;
      if ((poses[i].position - poses[j].position).squaredNorm() > max_distance_squared) continue;
      if (max_angle > 0.0 &&
          poses[i].orientation.angularDistance(poses[j].orientation) > max_angle) {
        continue;
      }
      truth.add(i, j);
      truth.add(j, i);
    }
  }
  truth.finalize();
  return truth;
}

std::vector<Pose> readKittiPoses(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw GroundTruthError("cannot open poses file " + path);
  std::vector<Pose> poses;
  std::string line;
  size_t number = 0;
  while (std::getline(file, line)) {
    ++number;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream values(line);
    double m[12];
    for (double& v : m) {
      if (!(values >> v)) {
        throw GroundTruthError(path + ":" + std::to_string(number) +
                               ": expected 12 numbers (row-major 3x4 [R|t])");
      }
    }
    Eigen::Matrix3d rotation;
    rotation << m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10];
    Pose pose;
    pose.position = Eigen::Vector3d(m[3], m[7], m[11]);
    pose.orientation = Eigen::Quaterniond(rotation).normalized();
    poses.push_back(pose);
  }
  return poses;
}

CameraIntrinsics readKittiIntrinsics(const std::string& path, const std::string& camera,
                                     const cv::Size& image_size) {
  std::ifstream file(path);
  if (!file) throw GroundTruthError("cannot open calibration file " + path);
  const std::string label = camera + ":";
  std::string line;
  while (std::getline(file, line)) {
    std::istringstream values(line);
    std::string first;
    if (!(values >> first) || first != label) continue;
    double p[12];
    for (double& v : p) {
      if (!(values >> v)) throw GroundTruthError(path + ": " + label + " needs 12 numbers");
    }
    CameraIntrinsics intrinsics;
    intrinsics.fx = p[0];
    intrinsics.cx = p[2];
    intrinsics.fy = p[5];
    intrinsics.cy = p[6];
    intrinsics.image_size = image_size;
    if (!intrinsics.valid()) throw GroundTruthError(path + ": " + label + " is not a camera");
    return intrinsics;
  }
  throw GroundTruthError(path + " has no line " + label);
}

std::vector<double> readNumbers(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw GroundTruthError("cannot open " + path);
  std::vector<double> numbers;
  double value;
  while (file >> value) numbers.push_back(value);
  if (!file.eof()) throw GroundTruthError(path + ": not a list of numbers");
  return numbers;
}

}  // namespace eval
}  // namespace landmark_loop_closure
