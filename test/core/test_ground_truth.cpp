#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <matio.h>
#include <zlib.h>

#include "landmark_loop_closure/eval/ground_truth.h"

using namespace landmark_loop_closure;
using namespace landmark_loop_closure::eval;
namespace fs = std::filesystem;

namespace {

using Bytes = std::vector<uint8_t>;

void append(Bytes* out, const void* data, size_t n) {
  const auto* bytes = static_cast<const uint8_t*>(data);
  out->insert(out->end(), bytes, bytes + n);
}

Bytes element(uint32_t type, const Bytes& data) {
  Bytes out;
  const uint32_t tag[2] = {type, static_cast<uint32_t>(data.size())};
  append(&out, tag, sizeof(tag));
  append(&out, data.data(), data.size());
  out.resize(out.size() + (8 - data.size() % 8) % 8, 0);
  return out;
}

template <typename T>
Bytes raw(const std::vector<T>& values) {
  Bytes out;
  append(&out, values.data(), values.size() * sizeof(T));
  return out;
}

// A miMATRIX element: flags, dims, name, then the given value sub-elements.
Bytes matrix(const std::string& name, uint8_t array_class, uint8_t flag_bits, int rows, int cols,
             const std::vector<Bytes>& parts) {
  Bytes body =
      element(6, raw(std::vector<uint32_t>{uint32_t(array_class) | (uint32_t(flag_bits) << 8), 0}));
  for (const Bytes& b : {element(5, raw(std::vector<int32_t>{rows, cols})),
                         element(1, Bytes(name.begin(), name.end()))}) {
    body.insert(body.end(), b.begin(), b.end());
  }
  for (const Bytes& part : parts) body.insert(body.end(), part.begin(), part.end());
  return element(14, body);
}

Bytes compressed(const Bytes& inner) {
  uLongf size = compressBound(inner.size());
  Bytes packed(size);
  compress2(packed.data(), &size, inner.data(), inner.size(), 6);
  packed.resize(size);
  Bytes out;
  const uint32_t tag[2] = {15, static_cast<uint32_t>(packed.size())};
  append(&out, tag, sizeof(tag));
  append(&out, packed.data(), packed.size());
  return out;
}

std::string writeMat(const std::string& file_name, const std::vector<Bytes>& elements) {
  const fs::path path = fs::temp_directory_path() / file_name;
  std::ofstream out(path, std::ios::binary);
  char header[128];
  std::memset(header, ' ', sizeof(header));
  std::memcpy(header, "MATLAB 5.0 MAT-file, test", 25);
  header[124] = 0x00;
  header[125] = 0x01;
  header[126] = 'I';
  header[127] = 'M';
  out.write(header, sizeof(header));
  for (const Bytes& e : elements) out.write(reinterpret_cast<const char*>(e.data()), e.size());
  return path.string();
}

// 4x4, ones at (1,0), (2,0), (3,2): column-major storage.
const std::vector<uint8_t> kColumnMajor = {0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0};

void expectSmallMatrix(const GroundTruth& truth) {
  EXPECT_EQ(truth.rows(), 4u);
  EXPECT_EQ(truth.cols(), 4u);
  EXPECT_EQ(truth.count(), 3u);
  EXPECT_TRUE(truth.contains(1, 0));
  EXPECT_TRUE(truth.contains(2, 0));
  EXPECT_TRUE(truth.contains(3, 2));
  EXPECT_FALSE(truth.contains(0, 1));
  EXPECT_EQ(truth.shape(), GroundTruth::Shape::kLowerTriangular);
  EXPECT_EQ(truth.rowsWithPositives(), 3u);
}

}  // namespace

TEST(MatReader, CompressedLogicalUint8) {
  const Bytes m = matrix("GT", 9, 0x02, 4, 4, {element(2, raw(kColumnMajor))});
  expectSmallMatrix(readMatGroundTruth(writeMat("logical.mat", {compressed(m)})));
}

TEST(MatReader, PlainDouble) {
  std::vector<double> values(kColumnMajor.begin(), kColumnMajor.end());
  const Bytes m = matrix("truth", 6, 0, 4, 4, {element(9, raw(values))});
  expectSmallMatrix(readMatGroundTruth(writeMat("double.mat", {m})));
}

TEST(MatReader, DoubleStoredAsUint8LikeMatlabDoes) {
  const Bytes m = matrix("truth", 6, 0, 4, 4, {element(2, raw(kColumnMajor))});
  expectSmallMatrix(readMatGroundTruth(writeMat("double_u8.mat", {compressed(m)})));
}

TEST(MatReader, Sparse) {
  // Nonzeros in column order: (1,0), (2,0), (3,2).
  const Bytes m = matrix("S", 5, 0x02, 4, 4,
                         {element(5, raw(std::vector<int32_t>{1, 2, 3})),
                          element(5, raw(std::vector<int32_t>{0, 2, 2, 3, 3})),
                          element(9, raw(std::vector<double>{1, 1, 1}))});
  expectSmallMatrix(readMatGroundTruth(writeMat("sparse.mat", {compressed(m)})));
}

TEST(MatReader, PicksTheNamedVariableAndListsOthersWhenMissing) {
  const Bytes first =
      matrix("other", 6, 0, 2, 2, {element(9, raw(std::vector<double>{1, 1, 1, 1}))});
  const Bytes second = matrix("GT", 9, 0x02, 4, 4, {element(2, raw(kColumnMajor))});
  const std::string path = writeMat("two.mat", {first, compressed(second)});
  expectSmallMatrix(readMatGroundTruth(path, "GT"));
  EXPECT_EQ(readMatGroundTruth(path).count(), 4u);  // First matrix when no name is given.
  try {
    readMatGroundTruth(path, "truth");
    FAIL();
  } catch (const GroundTruthError& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find("two.mat"), std::string::npos) << what;
    EXPECT_NE(what.find("other, GT"), std::string::npos) << what;
  }
}

TEST(MatReader, ClearErrorsForBadFiles) {
  const Bytes m = matrix("GT", 9, 0x02, 4, 4, {element(2, raw(kColumnMajor))});
  Bytes packed = compressed(m);
  packed.resize(packed.size() / 2);
  EXPECT_THROW(readMatGroundTruth(writeMat("truncated.mat", {packed})), GroundTruthError);
  Bytes corrupt = compressed(m);
  for (size_t i = 10; i < corrupt.size(); ++i) corrupt[i] ^= 0x5a;
  EXPECT_THROW(readMatGroundTruth(writeMat("corrupt.mat", {corrupt})), GroundTruthError);
  const fs::path text = fs::temp_directory_path() / "not_a_mat.mat";
  std::ofstream(text) << "hello";
  EXPECT_THROW(readMatGroundTruth(text.string()), GroundTruthError);
  EXPECT_THROW(readMatGroundTruth("/nonexistent.mat"), GroundTruthError);
}

// Writes `values` (column-major, rows x cols) as variable `name` through libmatio, in the given
// format: MAT_FT_MAT73 is an HDF5 file, as MATLAB's `save -v7.3` writes.
template <typename T>
std::string writeWithLibrary(const std::string& file_name, mat_ft version, const std::string& name,
                             matio_classes class_type, matio_types data_type, int rows, int cols,
                             std::vector<T> values, int flags = 0) {
  const fs::path path = fs::temp_directory_path() / file_name;
  fs::remove(path);
  mat_t* file = Mat_CreateVer(path.c_str(), nullptr, version);
  EXPECT_NE(file, nullptr);
  size_t dims[2] = {static_cast<size_t>(rows), static_cast<size_t>(cols)};
  matvar_t* variable =
      Mat_VarCreate(name.c_str(), class_type, data_type, 2, dims, values.data(), flags);
  EXPECT_EQ(Mat_VarWrite(file, variable, MAT_COMPRESSION_ZLIB), 0);
  Mat_VarFree(variable);
  Mat_Close(file);
  return path.string();
}

TEST(MatReader, Version73HdfFile) {
  const std::vector<double> values(kColumnMajor.begin(), kColumnMajor.end());
  const std::string path =
      writeWithLibrary("v73.mat", MAT_FT_MAT73, "GT", MAT_C_DOUBLE, MAT_T_DOUBLE, 4, 4, values);
  char signature[19] = {};
  std::ifstream(path, std::ios::binary).read(signature, sizeof(signature));
  ASSERT_EQ(std::string(signature, sizeof(signature)), "MATLAB 7.3 MAT-file");
  std::ifstream hdf(path, std::ios::binary);
  hdf.seekg(512);  // v7.3 = a 512-byte MATLAB header, then an HDF5 file.
  char hdf_signature[4] = {};
  hdf.read(hdf_signature, 4);
  ASSERT_EQ(std::string(hdf_signature + 1, 3), "HDF");
  expectSmallMatrix(readMatGroundTruth(path, "GT"));
  expectSmallMatrix(readMatGroundTruth(path));
}

TEST(MatReader, Version73LogicalAndSparse) {
  expectSmallMatrix(
      readMatGroundTruth(writeWithLibrary("v73_logical.mat", MAT_FT_MAT73, "truth", MAT_C_UINT8,
                                          MAT_T_UINT8, 4, 4, kColumnMajor, MAT_F_LOGICAL)));
  // (1,0), (2,0), (3,2) in compressed-column form.
  std::vector<mat_uint32_t> row_index = {1, 2, 3};
  std::vector<mat_uint32_t> column_start = {0, 2, 2, 3, 3};
  std::vector<double> ones = {1, 1, 1};
  mat_sparse_t sparse{};
  sparse.nzmax = 3;
  sparse.ir = row_index.data();
  sparse.nir = 3;
  sparse.jc = column_start.data();
  sparse.njc = 5;
  sparse.ndata = 3;
  sparse.data = ones.data();
  for (const mat_ft version : {MAT_FT_MAT73, MAT_FT_MAT5}) {
    SCOPED_TRACE(version == MAT_FT_MAT73 ? "v7.3" : "v5");
    const fs::path path = fs::temp_directory_path() / "sparse_library.mat";
    fs::remove(path);
    mat_t* file = Mat_CreateVer(path.c_str(), nullptr, version);
    ASSERT_NE(file, nullptr);
    size_t dims[2] = {4, 4};
    matvar_t* variable =
        Mat_VarCreate("S", MAT_C_SPARSE, MAT_T_DOUBLE, 2, dims, &sparse, MAT_F_DONT_COPY_DATA);
    ASSERT_EQ(Mat_VarWrite(file, variable, MAT_COMPRESSION_ZLIB), 0);
    variable->data = nullptr;  // The vectors above own it.
    Mat_VarFree(variable);
    Mat_Close(file);
    expectSmallMatrix(readMatGroundTruth(path.string(), "S"));
  }
}

TEST(MatReader, ColumnBlocksGiveEveryPositiveOnce) {
  // One positive per column, just below the diagonal; blocks of 7 columns (the last one shorter)
  // check every block edge, in both formats.
  const int n = 200;
  std::vector<int64_t> values(static_cast<size_t>(n) * n, 0);
  for (int column = 0; column + 1 < n; ++column) values[size_t(column) * n + column + 1] = 7;
  for (const mat_ft version : {MAT_FT_MAT73, MAT_FT_MAT5}) {
    SCOPED_TRACE(version == MAT_FT_MAT73 ? "v7.3" : "v5");
    const std::string path =
        writeWithLibrary("blocks.mat", version, "GT", MAT_C_INT64, MAT_T_INT64, n, n, values);
    const GroundTruth truth = readMatGroundTruth(path, "GT", 7 * n * sizeof(int64_t));
    EXPECT_EQ(truth.count(), size_t(n - 1));
    EXPECT_EQ(truth.rowsWithPositives(), size_t(n - 1));
    EXPECT_TRUE(truth.contains(n - 1, n - 2));
    EXPECT_TRUE(truth.contains(7, 6));
    EXPECT_TRUE(truth.contains(8, 7));
    EXPECT_EQ(truth.shape(), GroundTruth::Shape::kLowerTriangular);
    EXPECT_EQ(readMatGroundTruth(path, "GT", 1).count(), size_t(n - 1));  // One column a block.
  }
}

TEST(GroundTruth, UndirectedAddsTheTranspose) {
  GroundTruth truth(3, 3);
  truth.add(2, 0);
  truth.finalize();
  const GroundTruth both = truth.undirected();
  EXPECT_TRUE(both.contains(0, 2));
  EXPECT_TRUE(both.contains(2, 0));
  EXPECT_EQ(both.shape(), GroundTruth::Shape::kSymmetric);
}

TEST(GroundTruth, AlignedTraversalsWithTolerance) {
  const GroundTruth truth = alignedGroundTruth(10, 10, 2);
  EXPECT_EQ(truth.positives(0), (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_EQ(truth.positives(5), (std::vector<uint32_t>{3, 4, 5, 6, 7}));
  EXPECT_EQ(truth.positives(9), (std::vector<uint32_t>{7, 8, 9}));
}

TEST(GroundTruth, AlignedTraversalsCountAStopAsOnePlace) {
  // Frames 3-6 are a stop (both traversals stand): frames 2-6 show one place.
  std::vector<bool> stopped(12, false);
  for (int i = 3; i <= 6; ++i) stopped[i] = true;
  const GroundTruth truth = alignedGroundTruth(12, 12, 1, stopped);
  EXPECT_EQ(truth.positives(2), (std::vector<uint32_t>{1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(truth.positives(5), (std::vector<uint32_t>{1, 2, 3, 4, 5, 6, 7}));
  EXPECT_EQ(truth.positives(8), (std::vector<uint32_t>{7, 8, 9}));
  EXPECT_EQ(truth.positives(0), (std::vector<uint32_t>{0, 1}));
  // Without stops it is the plain tolerance; more queries than database images stay in range.
  const GroundTruth plain = alignedGroundTruth(14, 10, 1, {});
  EXPECT_EQ(plain.positives(5), (std::vector<uint32_t>{4, 5, 6}));
  EXPECT_EQ(plain.positives(10), (std::vector<uint32_t>{9}));
  EXPECT_TRUE(plain.positives(12).empty());
}

TEST(GroundTruth, FromPosesNeedsDistanceHeadingAndTimeGap) {
  const std::vector<Pose> poses = {planarPose(0, 0, 0), planarPose(0.5, 0, 0), planarPose(20, 0, 0),
                                   planarPose(0.2, 0, 0), planarPose(0.1, 0, 3.0)};
  const std::vector<double> stamps = {0, 1, 20, 40, 60};
  const GroundTruth truth = poseGroundTruth(poses, stamps, 1.0, 0.5, 10.0);
  EXPECT_TRUE(truth.contains(3, 0));
  EXPECT_TRUE(truth.contains(0, 3));
  EXPECT_TRUE(truth.contains(3, 1));
  EXPECT_FALSE(truth.contains(1, 0));  // Close in time.
  EXPECT_FALSE(truth.contains(4, 0));  // Facing the other way.
  EXPECT_FALSE(truth.contains(2, 0));  // Far.
}

// Every ground-truth file shipped in ../shared/data, checked against counts computed with an
// independent parser: shape, number of positive pairs, images that have a loop, triangle.
TEST(KittiCalibration, GivesTheNamedCamerasIntrinsics) {
  const fs::path path = fs::temp_directory_path() / "lcd_test_kitti_calib.txt";
  {
    std::ofstream file(path);
    // KITTI odometry sequence 00's calib.txt, first two lines.
    file << "P0: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 0.000000000000e+00 "
            "0.000000000000e+00 7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 "
            "0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 0.000000000000e+00\n"
         << "P1: 7.188560000000e+02 0 6.071928000000e+02 -3.861448000000e+02 0 "
            "7.188560000000e+02 1.852157000000e+02 0 0 0 1 0\n";
  }
  const CameraIntrinsics k = readKittiIntrinsics(path.string(), "P0", cv::Size(1241, 376));
  EXPECT_DOUBLE_EQ(k.fx, 718.856);
  EXPECT_DOUBLE_EQ(k.fy, 718.856);
  EXPECT_DOUBLE_EQ(k.cx, 607.1928);
  EXPECT_DOUBLE_EQ(k.cy, 185.2157);
  EXPECT_EQ(k.image_size, cv::Size(1241, 376));
  EXPECT_THROW(readKittiIntrinsics(path.string(), "P2", cv::Size(1241, 376)), GroundTruthError);
  EXPECT_THROW(readKittiIntrinsics("/nonexistent/calib.txt", "P0", cv::Size(1, 1)),
               GroundTruthError);
  {
    std::ofstream file(path);
    file << "P0: 718.856 0 607.19\n";
  }
  EXPECT_THROW(readKittiIntrinsics(path.string(), "P0", cv::Size(1241, 376)), GroundTruthError);
  fs::remove(path);
}

TEST(SharedGroundTruthFiles, ReadWithTheExpectedShapeAndLoops) {
  const fs::path folder = fs::path(PACKAGE_SOURCE_DIR) / ".." / "shared" / "data" / "gt_matrices";
  if (!fs::exists(folder)) GTEST_SKIP() << folder << " is absent";
  struct Expected {
    const char* file;
    const char* variable;
    size_t n;
    size_t positives;
    size_t rows_with_loops;
    GroundTruth::Shape shape;
  };
  using S = GroundTruth::Shape;
  const Expected expected[] = {
      {"100909_1210_GT_labeled.mat", "GT", 3851, 57809, 2155, S::kLowerTriangular},
      {"100909_1410_GT_labeled.mat", "GT", 4179, 80337, 2489, S::kLowerTriangular},
      {"180809_1545_GT_labeled.mat", "GT", 4287, 67873, 2376, S::kLowerTriangular},
      {"190809_0845_GT_labeled.mat", "GT", 4363, 66154, 2323, S::kLowerTriangular},
      {"Lip6IndoorGroundTruth.mat", "truth", 388, 884, 220, S::kLowerTriangular},
      {"Lip6OutdoorGroundTruth.mat", "truth", 1063, 3704, 603, S::kLowerTriangular},
      {"NewCollegeGroundTruth.mat", "truth", 2146, 14832, 853, S::kLowerTriangular},
      {"city_GT_final.mat", "GT", 1237, 8321, 551, S::kLowerTriangular},
      {"groundTruth_KITTI00.mat", "groundTruthMatrixKITTI00_ICRA18", 4541, 31922, 788,
       S::kLowerTriangular},
      {"groundTruth_KITTI_05.mat", "groundTruthMatrixKITTI05_ICRA18", 2761, 10558, 415,
       S::kLowerTriangular},
      {"kitti02GroundTruth.mat", "truth", 4661, 4037, 321, S::kLowerTriangular},
      {"kitti06GroundTruth.mat", "truth", 1101, 3287, 272, S::kLowerTriangular},
      {"malaga_GT_final.mat", "GT", 3474, 34828, 722, S::kLowerTriangular},
      {"newcollege_GT.mat", "gt", 2624, 46753, 1433, S::kUpperTriangular},
  };
  for (const Expected& e : expected) {
    SCOPED_TRACE(e.file);
    const GroundTruth truth = readMatGroundTruth((folder / e.file).string(), e.variable);
    EXPECT_EQ(truth.rows(), e.n);
    EXPECT_EQ(truth.cols(), e.n);
    EXPECT_EQ(truth.count(), e.positives);
    EXPECT_EQ(truth.rowsWithPositives(), e.rows_with_loops);
    EXPECT_EQ(truth.shape(), e.shape);
    EXPECT_EQ(readMatGroundTruth((folder / e.file).string()).count(), e.positives);
  }
}

TEST(SharedGroundTruthFiles, BicoccaStreamsWithoutHoldingTheDenseMatrix) {
  const fs::path file = fs::path(PACKAGE_SOURCE_DIR) / ".." / "shared" / "data" / "gt_matrices" /
                        "new_GT_biccoca.mat";
  if (!fs::exists(file)) GTEST_SKIP() << file << " is absent";
  const GroundTruth truth = readMatGroundTruth(file.string(), "new_GT_biccoca");
  EXPECT_EQ(truth.rows(), 26335u);
  EXPECT_EQ(truth.cols(), 26335u);
  // Measured with this reader (too large for the independent parser used for the others).
  EXPECT_EQ(truth.count(), 254055u);
  EXPECT_EQ(truth.rowsWithPositives(), 3553u);
  EXPECT_EQ(truth.shape(), GroundTruth::Shape::kUpperTriangular);
}

TEST(SharedKittiPoses, ReadAndGiveLoopsOnSequence00) {
  const fs::path folder = fs::path(PACKAGE_SOURCE_DIR) / ".." / "shared" / "data" / "kitti_poses";
  if (!fs::exists(folder)) GTEST_SKIP() << folder << " is absent";
  const std::vector<Pose> poses = readKittiPoses((folder / "00.txt").string());
  const std::vector<double> times = readNumbers((folder / "00_times.txt").string());
  ASSERT_EQ(poses.size(), 4541u);
  ASSERT_EQ(times.size(), 4541u);
  const GroundTruth truth = poseGroundTruth(poses, times, 5.0, 0.0, 30.0);
  EXPECT_GT(truth.rowsWithPositives(), 500u);  // KITTI 00 revisits much of its route.
  EXPECT_EQ(truth.shape(), GroundTruth::Shape::kSymmetric);
}
