#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "landmark_loop_closure/geometry/geometric_verification.h"
#include "landmark_loop_closure/geometry/pose.h"

namespace landmark_loop_closure {
namespace eval {

/// Which images show the same place: a sparse binary matrix, entry (row, col) = 1 when image
/// `row` and image `col` are the same place. For a single sequence rows and columns are the same
/// images; for two traversals rows are queries and columns database images.
class GroundTruth {
 public:
  enum class Shape { kEmpty, kSymmetric, kLowerTriangular, kUpperTriangular, kMixed };

  GroundTruth() = default;
  GroundTruth(size_t rows, size_t cols);

  /// Marks (row, col); call finalize() once after the last add().
  void add(size_t row, size_t col);
  void finalize();

  size_t rows() const { return rows_; }
  size_t cols() const { return cols_; }
  /// Number of positive entries.
  size_t count() const;
  bool contains(size_t row, size_t col) const;
  const std::vector<uint32_t>& positives(size_t row) const { return positives_[row]; }
  size_t rowsWithPositives() const;
  Shape shape() const;
  /// Square matrix with every pair in both directions, for sequences whose files list only
  /// (later, earlier) or only (earlier, later).
  GroundTruth undirected() const;

 private:
  size_t rows_ = 0;
  size_t cols_ = 0;
  std::vector<std::vector<uint32_t>> positives_;
};

const char* toString(GroundTruth::Shape shape);

class GroundTruthError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Memory for one block of columns of a dense .mat matrix (below).
constexpr size_t kMatBlockBytes = size_t{256} << 20;

/// Reads a 2-D numeric or logical matrix (any MATLAB numeric class, dense or sparse) from a
/// MATLAB .mat file of any version MATLAB writes (v4, v5/v7 plain or compressed, v7.3 = HDF5),
/// through libmatio; nonzero = same place. `variable` empty takes the first 2-D numeric matrix.
/// A dense matrix is read `block_bytes` of whole columns at a time, so a 26k x 26k logical matrix
/// (693 MB) needs that much memory and its positives. Throws GroundTruthError naming the file and
/// the problem.
GroundTruth readMatGroundTruth(const std::string& path, const std::string& variable = "",
                               size_t block_bytes = kMatBlockBytes);

/// Throws GroundTruthError when `truth` marks no pair at all (an all-zero matrix: every measure
/// would read 0 without a word); `source` names where it came from.
void requirePositives(const GroundTruth& truth, const std::string& source);

/// Two aligned traversals: query i shows the place of database image j when |i - j| <= tolerance.
/// `stopped[i]` marks a frame at which both traversals stand still (a train at a station): it
/// shows the place of the frame before it, so a stop counts as one frame, and query i and
/// database j are the same place when at most `tolerance` moving frames lie between them.
GroundTruth alignedGroundTruth(size_t queries, size_t database, int tolerance,
                               const std::vector<bool>& stopped = {});

/// One sequence with poses: i and j are the same place when their positions are within
/// `max_distance` metres, their headings within `max_angle` radians (<= 0: any heading), and
/// their stamps at least `min_time_gap` seconds apart.
GroundTruth poseGroundTruth(const std::vector<Pose>& poses, const std::vector<double>& stamps,
                            double max_distance, double max_angle, double min_time_gap);

/// KITTI odometry poses: one row-major 3x4 [R|t] per line. Throws GroundTruthError.
std::vector<Pose> readKittiPoses(const std::string& path);
/// Pinhole intrinsics of one camera from a KITTI odometry calib.txt: the line "`camera`: " holds
/// its row-major 3x4 projection matrix (P0: left grey). `image_size` is the images' size (the file
/// does not say). Throws GroundTruthError.
CameraIntrinsics readKittiIntrinsics(const std::string& path, const std::string& camera,
                                     const cv::Size& image_size);
/// One number per line (KITTI times.txt). Throws GroundTruthError.
std::vector<double> readNumbers(const std::string& path);

}  // namespace eval
}  // namespace landmark_loop_closure
