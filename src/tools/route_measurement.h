#pragma once

// lcd_bench_map --measure-route: how the shipped descriptor's vectors of real images spread, next
// to the benchmark's synthetic routes, so the route the map benchmark stores can be checked
// against real data. For each set: the cosine of unrelated places (more than 5 places apart), of
// neighbouring places, the share of a vector's energy all of them share (the mean's squared
// norm), and the slope of the variance spectrum over principal directions 2-60 (variance ~ k^-a).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/imgcodecs.hpp>

#include "bench_workload.h"

namespace landmark_loop_closure {
namespace bench {

// Rows: unit vectors; place_of(i): where on the route row i was taken.
inline void printSpread(const std::string& name, const Eigen::MatrixXf& rows,
                        const std::vector<int>& place_of) {
  const Eigen::Index n = rows.rows();
  double unrelated = 0.0;
  double unrelated_squares = 0.0;
  double neighbours = 0.0;
  size_t unrelated_count = 0;
  size_t neighbour_count = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = i + 1; j < n; ++j) {
      const double cosine = rows.row(i).dot(rows.row(j));
      const int apart = std::abs(place_of[i] - place_of[j]);
      if (apart > 5) {
        unrelated += cosine;
        unrelated_squares += cosine * cosine;
        ++unrelated_count;
      } else if (apart == 1 && j == i + 1) {
        neighbours += cosine;
        ++neighbour_count;
      }
    }
  }
  const double mean = unrelated / std::max<size_t>(unrelated_count, 1);
  const double spread = std::sqrt(
      std::max(0.0, unrelated_squares / std::max<size_t>(unrelated_count, 1) - mean * mean));
  const Eigen::RowVectorXf centre = rows.colwise().mean();
  const Eigen::MatrixXf centred = rows.rowwise() - centre;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXf> solver(centred * centred.transpose());
  const Eigen::VectorXf variance = solver.eigenvalues().reverse();
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  int fitted = 0;
  for (int k = 2; k <= std::min<int>(60, static_cast<int>(variance.size())); ++k) {
    if (variance[k - 1] <= 0.0f) break;
    const double x = std::log(k);
    const double y = std::log(variance[k - 1]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
    ++fitted;
  }
  const double slope = fitted > 1 ? -(fitted * sxy - sx * sy) / (fitted * sxx - sx * sx) : 0.0;
  std::printf("| %s | %lld | %.3f +- %.3f | %.3f | %.2f | %.2f |\n", name.c_str(),
              static_cast<long long>(n), mean, spread,
              neighbours / std::max<size_t>(neighbour_count, 1), centre.squaredNorm(), slope);
}

// Describes every image in `folders` (sorted by name; image i of each folder is place i) and
// prints their spread, then that of 300 keyframes of each synthetic route (every 10th one).
inline int measureRoutes(const DescriptorExtractor& extractor,
                         const std::vector<std::string>& folders) {
  std::vector<std::vector<float>> vectors;
  std::vector<int> places;
  for (const std::string& folder : folders) {
    std::vector<std::filesystem::path> images;
    for (const auto& entry : std::filesystem::directory_iterator(folder)) {
      const std::string extension = entry.path().extension().string();
      if (extension == ".jpg" || extension == ".png") images.push_back(entry.path());
    }
    std::sort(images.begin(), images.end());
    for (size_t i = 0; i < images.size(); ++i) {
      const cv::Mat image = cv::imread(images[i].string());
      if (image.empty()) continue;
      vectors.push_back(extractor.describe(image).global);
      places.push_back(static_cast<int>(i));
    }
  }
  if (vectors.size() < 20) {
    std::fprintf(stderr, "--measure-route needs at least 20 images\n");
    return 1;
  }
  const auto matrixOf = [](std::vector<std::vector<float>> list) {
    Eigen::MatrixXf rows(static_cast<Eigen::Index>(list.size()),
                         static_cast<Eigen::Index>(list.front().size()));
    for (size_t i = 0; i < list.size(); ++i) {
      normalise(&list[i]);
      rows.row(static_cast<Eigen::Index>(i)) =
          Eigen::Map<const Eigen::RowVectorXf>(list[i].data(), rows.cols());
    }
    return rows;
  };
  std::printf(
      "| vectors | count | unrelated places' cosine | neighbours' cosine | shared energy | "
      "spectrum slope |\n|---|---|---|---|---|---|\n");
  printSpread("real images", matrixOf(vectors), places);
  const int dimension = static_cast<int>(vectors.front().size());
  for (const RouteShape shape : {RouteShape::kMeasured, RouteShape::kIsotropic}) {
    Route route(dimension, 7, shape);
    std::vector<std::vector<float>> synthetic;
    std::vector<int> route_places;
    for (int i = 0; i < 300; ++i) {
      for (int skip = 0; skip < 9; ++skip) route.next();
      synthetic.push_back(route.next());
      route_places.push_back(i);
    }
    printSpread(shape == RouteShape::kMeasured ? "route measured (every 10th keyframe)"
                                               : "route isotropic (every 10th keyframe)",
                matrixOf(synthetic), route_places);
  }
  return 0;
}

}  // namespace bench
}  // namespace landmark_loop_closure
