// Writes a tiny image sequence and its ground truth as MATLAB writes it with `save -v7.3` (an
// HDF5 file behind a 512-byte MATLAB header), through libmatio: tool_command_lines has
// lcd_evaluate --gt-mat read it.
//   write_mat73_fixture FOLDER   -> FOLDER/images/000.png ... 005.png, FOLDER/truth_v73.mat
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <matio.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: write_mat73_fixture FOLDER\n");
    return 2;
  }
  const std::filesystem::path folder = argv[1];
  std::filesystem::create_directories(folder / "images");
  constexpr int kImages = 6;
  cv::RNG random(7);
  std::vector<cv::Mat> places;
  for (int i = 0; i < kImages; ++i) {
    // Images 3-5 show places 0-2 again, a little noisier.
    cv::Mat image(120, 160, CV_8UC1);
    if (i < 3) {
      random.fill(image, cv::RNG::UNIFORM, 0, 255);
      places.push_back(image);
    } else {
      cv::Mat noise(image.size(), CV_8UC1);
      random.fill(noise, cv::RNG::UNIFORM, 0, 20);
      cv::add(places[i - 3], noise, image);
    }
    char name[16];
    std::snprintf(name, sizeof(name), "%03d.png", i);
    if (!cv::imwrite((folder / "images" / name).string(), image)) return 1;
  }
  // Images 3-5 revisit 0-2: ones below the diagonal, column-major, as logical.
  std::vector<unsigned char> truth(kImages * kImages, 0);
  for (int i = 0; i < 3; ++i) truth[static_cast<size_t>(i) * kImages + i + 3] = 1;
  const std::string path = (folder / "truth_v73.mat").string();
  std::filesystem::remove(path);
  mat_t* file = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT73);
  if (file == nullptr) return 1;
  size_t dims[2] = {kImages, kImages};
  matvar_t* variable =
      Mat_VarCreate("GT", MAT_C_UINT8, MAT_T_UINT8, 2, dims, truth.data(), MAT_F_LOGICAL);
  const bool written =
      variable != nullptr && Mat_VarWrite(file, variable, MAT_COMPRESSION_ZLIB) == 0;
  Mat_VarFree(variable);
  Mat_Close(file);
  return written ? 0 : 1;
}
