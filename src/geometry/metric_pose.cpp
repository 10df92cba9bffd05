#include "landmark_loop_closure/geometry/metric_pose.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>

#include "landmark_loop_closure/geometry/pose_jacobian.h"

namespace landmark_loop_closure {

namespace {

constexpr double kDegreesToRadians = M_PI / 180.0;
constexpr int kMaxPnpRefitRounds = 5;

bool finite(const cv::Point3f& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}

void resetPoints(LocalFeatures* features) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  features->points3d.assign(features->points.size(), cv::Point3f(nan, nan, nan));
  features->depth_sd.assign(features->points.size(), nan);
}

struct PnpProblem {
  std::vector<Eigen::Vector3d> object;      // In the match camera frame.
  std::vector<Eigen::Matrix3d> covariance;  // Of each object point.
  std::vector<Eigen::Vector2d> pixel;       // In the query image.
  // Per point: the inverse Cholesky factor of its pixel covariance in the query image (keypoint
  // noise plus the point's own uncertainty projected), fixed for one round of refinement.
  std::vector<Eigen::Matrix2d> whitener;
};

// The pose moved by p = (translation step, rotation vector applied on the left): pose_jacobian.h's
// order, the covariance's (x, y, z, rotation about x, y, z).
RelativePose perturbed(const RelativePose& pose, const Eigen::Matrix<double, 6, 1>& p) {
  const Eigen::Vector3d rotation_vector = p.tail<3>();
  const double angle = rotation_vector.norm();
  RelativePose moved = pose;
  if (angle > 0.0) {
    moved.rotation = Eigen::AngleAxisd(angle, rotation_vector / angle) * pose.rotation;
  }
  moved.translation += p.head<3>();
  return moved;
}

Eigen::Vector2d project(const Eigen::Vector3d& x, const CameraIntrinsics& k) {
  return {k.fx * x.x() / x.z() + k.cx, k.fy * x.y() / x.z() + k.cy};
}

// Reprojection errors in pixels, two per point; a point behind the camera gets a large one.
Eigen::VectorXd pixelErrors(const PnpProblem& problem, const RelativePose& pose,
                            const CameraIntrinsics& k) {
  Eigen::VectorXd r(2 * static_cast<Eigen::Index>(problem.object.size()));
  for (size_t i = 0; i < problem.object.size(); ++i) {
    const Eigen::Vector3d x = pose.rotation * problem.object[i] + pose.translation;
    const auto row = 2 * static_cast<Eigen::Index>(i);
    r.segment<2>(row) = x.z() > 1e-6 ? Eigen::Vector2d(project(x, k) - problem.pixel[i])
                                     : Eigen::Vector2d(1e3, 1e3);
  }
  return r;
}

// Pixel errors divided by their expected spread: unit variance for a correct pose.
Eigen::VectorXd residuals(const PnpProblem& problem, const RelativePose& pose,
                          const CameraIntrinsics& k) {
  Eigen::VectorXd r = pixelErrors(problem, pose, k);
  for (size_t i = 0; i < problem.object.size(); ++i) {
    const auto row = 2 * static_cast<Eigen::Index>(i);
    r.segment<2>(row) = problem.whitener[i] * r.segment<2>(row);
  }
  return r;
}

void updateWhiteners(const RelativePose& pose, const CameraIntrinsics& k, double keypoint_sd_px,
                     PnpProblem* problem) {
  problem->whitener.resize(problem->object.size());
  for (size_t i = 0; i < problem->object.size(); ++i) {
    const Eigen::Vector3d x = pose.rotation * problem->object[i] + pose.translation;
    Eigen::Matrix2d pixel_covariance =
        keypoint_sd_px * keypoint_sd_px * Eigen::Matrix2d::Identity();
    if (x.z() > 1e-6) {
      Eigen::Matrix<double, 2, 3> projection;
      projection << k.fx / x.z(), 0.0, -k.fx * x.x() / (x.z() * x.z()), 0.0, k.fy / x.z(),
          -k.fy * x.y() / (x.z() * x.z());
      const Eigen::Matrix<double, 2, 3> through = projection * pose.rotation;
      pixel_covariance += through * problem->covariance[i] * through.transpose();
    }
    problem->whitener[i] = pixel_covariance.llt().matrixL().solve(Eigen::Matrix2d::Identity());
  }
}

// A point's covariance: depth_sd along its ray, a keypoint's spread across it.
Eigen::Matrix3d pointCovariance(const Eigen::Vector3d& point, double depth_sd, double focal,
                                double keypoint_sd_px) {
  const Eigen::Vector3d ray = point.normalized();
  const double lateral_sd = keypoint_sd_px * point.norm() / focal;
  const Eigen::Matrix3d along = ray * ray.transpose();
  return depth_sd * depth_sd * along +
         lateral_sd * lateral_sd * (Eigen::Matrix3d::Identity() - along);
}

Eigen::MatrixXd jacobian(const PnpProblem& problem, const RelativePose& pose,
                         const CameraIntrinsics& k) {
  static const std::vector<int> all = allColumns(6);
  return poseJacobian(
      [&](const Eigen::VectorXd& p) {
        return residuals(problem, perturbed(pose, Eigen::Matrix<double, 6, 1>(p)), k);
      },
      6, all);
}

// Levenberg-Marquardt on the reprojection errors.
void refine(const PnpProblem& problem, const CameraIntrinsics& k, RelativePose* pose) {
  double cost = residuals(problem, *pose, k).squaredNorm();
  double damping = 1e-3;
  for (int iteration = 0; iteration < 50 && damping < 1e8; ++iteration) {
    const Eigen::VectorXd r = residuals(problem, *pose, k);
    const Eigen::MatrixXd j = jacobian(problem, *pose, k);
    Eigen::Matrix<double, 6, 6> a = j.transpose() * j;
    a.diagonal() *= 1.0 + damping;
    const Eigen::Matrix<double, 6, 1> step = a.ldlt().solve(-j.transpose() * r);
    const RelativePose candidate = perturbed(*pose, step);
    const double candidate_cost = residuals(problem, candidate, k).squaredNorm();
    if (candidate_cost < cost) {
      const bool converged = cost - candidate_cost < 1e-10 * cost;
      *pose = candidate;
      cost = candidate_cost;
      damping *= 0.1;
      if (converged) break;
    } else {
      damping *= 10.0;
    }
  }
}

// Points whose whitened error lies inside the 99 % region of two unit-variance dimensions,
// after scaling by `scale` (the residuals' spread when it exceeds the assumed noise).
std::vector<size_t> selectInliers(const PnpProblem& all, const RelativePose& pose,
                                  const CameraIntrinsics& k, double scale) {
  constexpr double kChiSquared2Dof99 = 9.21;
  const Eigen::VectorXd r = residuals(all, pose, k);
  std::vector<size_t> chosen;
  for (size_t i = 0; i < all.object.size(); ++i) {
    const auto row = 2 * static_cast<Eigen::Index>(i);
    if (r.segment<2>(row).squaredNorm() <= kChiSquared2Dof99 * scale * scale) chosen.push_back(i);
  }
  return chosen;
}

// The spread of the whitened errors relative to their assumed unit variance, from their median
// (robust to the outliers still among them), at least 1.
double noiseScale(const PnpProblem& problem, const RelativePose& pose, const CameraIntrinsics& k) {
  const Eigen::VectorXd r = residuals(problem, pose, k);
  std::vector<double> norms;
  for (Eigen::Index row = 0; row + 1 < r.size(); row += 2)
    norms.push_back(r.segment<2>(row).norm());
  if (norms.empty()) return 1.0;
  std::nth_element(norms.begin(), norms.begin() + norms.size() / 2, norms.end());
  constexpr double kRayleighMedian = 1.1774;  // Median norm of two unit Gaussians.
  return std::max(1.0, norms[norms.size() / 2] / kRayleighMedian);
}

PnpProblem subset(const PnpProblem& all, const std::vector<size_t>& indices) {
  PnpProblem chosen;
  for (const size_t i : indices) {
    chosen.object.push_back(all.object[i]);
    chosen.covariance.push_back(all.covariance[i]);
    chosen.pixel.push_back(all.pixel[i]);
    if (!all.whitener.empty()) chosen.whitener.push_back(all.whitener[i]);
  }
  return chosen;
}

}  // namespace

const ParameterTable<MetricPoseOptions>& MetricPoseOptions::parameters() {
  using O = MetricPoseOptions;
  static const auto table =
      ParameterTable<O>("advanced/metric_pose/",
                        "metric relative pose: keypoint depths of the match keyframe, then PnP.")
          .flag("triangulate_from_odometry", &O::triangulate_from_odometry,
                "without a depth image, triangulate each keyframe's keypoints against the "
                "previous keyframes with the odometry's motion (its drift over a few keyframes is "
                "small): this gives the metric scale.")
          .number("min_triangulation_angle_deg", &O::min_triangulation_angle_deg,
                  openBetween(0, 90, true, true),
                  "rays meeting at a smaller angle give too noisy a depth.")
          .evaluationOnly()
          .number("max_point_depth_m", &O::max_point_depth_m, above(0),
                  "farther points, and depth readings, are dropped.")
          .evaluationOnly()
          .number("max_reprojection_px", &O::max_reprojection_px, above(0),
                  "a triangulated point must reproject this close in the other view; also the "
                  "PnP RANSAC inlier threshold.")
          .evaluationOnly()
          .integer("min_inliers", &O::min_inliers, between(6, 10000),
                   "fewer PnP inliers: the loop keeps no metric pose (still verified).")
          .number("max_translation_sd_m", &O::max_translation_sd_m, above(0),
                  "larger uncertainty: no metric pose (see the candidate's detail).")
          .evaluationOnly()
          .number("max_rotation_sd_deg", &O::max_rotation_sd_deg, above(0), "")
          .evaluationOnly()
          .number("depth_image_metres_per_unit", &O::depth_image_metres_per_unit, above(0),
                  "16UC1 depth images (millimetres); 32FC1 ones are metres.")
          .number("depth_image_sd_per_m2", &O::depth_image_sd_per_m2, atLeast(0),
                  "depth-camera noise: sd = this * depth^2 (metres).");
  return table;
}

std::string MetricPoseOptions::validate() const { return parameters().check(*this); }

bool hasUsableDepth(const cv::Mat& depth) {
  if (depth.empty()) return false;
  if (depth.depth() == CV_16U) return cv::countNonZero(depth.reshape(1)) > 0;
  if (depth.depth() != CV_32F) return false;
  for (int r = 0; r < depth.rows; ++r) {
    const float* row = depth.ptr<float>(r);
    for (int c = 0; c < depth.cols * depth.channels(); ++c) {
      if (std::isfinite(row[c]) && row[c] > 0.0f) return true;
    }
  }
  return false;
}

int triangulateKeypoints(const LocalFeatures& neighbour,
                         const Eigen::Isometry3d& neighbour_in_keyframe,
                         const CameraIntrinsics& intrinsics,
                         const VerificationOptions& verification, const MetricPoseOptions& options,
                         LocalFeatures* keyframe) {
  if (keyframe->points3d.size() != keyframe->points.size() ||
      keyframe->depth_sd.size() != keyframe->points.size()) {
    resetPoints(keyframe);
  }
  const Eigen::Vector3d t = neighbour_in_keyframe.translation();
  if (!intrinsics.valid() || neighbour.image_size != keyframe->image_size || !t.allFinite() ||
      t.norm() < 1e-6) {
    return 0;
  }
  const CameraIntrinsics k = intrinsics.scaledTo(keyframe->image_size);
  const Eigen::Matrix3d rotation = neighbour_in_keyframe.linear();
  const double min_angle_cosine = std::cos(options.min_triangulation_angle_deg * kDegreesToRadians);
  const double focal = 0.5 * (k.fx + k.fy);
  // Depth along the keyframe's ray of the point closest to both rays (least squares); NaN when
  // it lies behind either camera.
  auto depthAlongRay = [&](const Eigen::Vector3d& ray, const Eigen::Vector3d& neighbour_ray) {
    Eigen::Matrix<double, 3, 2> a;
    a << ray, -neighbour_ray;
    const Eigen::Vector2d depths = a.colPivHouseholderQr().solve(t);
    return depths(0) > 0.0 && depths(1) > 0.0 ? depths(0) : NAN;
  };
  const double pixel_step = std::max(verification.keypoint_sigma_px, 0.1);
  int found = 0;
  for (const auto& [keyframe_index, neighbour_index] :
       ratioTestMatches(*keyframe, neighbour, verification.ratio_test)) {
    const cv::Point2f& here = keyframe->points[static_cast<size_t>(keyframe_index)];
    const cv::Point2f& there = neighbour.points[static_cast<size_t>(neighbour_index)];
    const Eigen::Vector3d ray = k.ray(here);
    const Eigen::Vector3d neighbour_ray = rotation * k.ray(there);
    if (ray.normalized().dot(neighbour_ray.normalized()) > min_angle_cosine) continue;
    const double depth = depthAlongRay(ray, neighbour_ray);
    if (!(depth > 0.0 && depth <= options.max_point_depth_m)) continue;
    const Eigen::Vector3d point = depth * ray;
    const Eigen::Vector3d in_neighbour = rotation.transpose() * (point - t);
    if (in_neighbour.z() <= 0.0) continue;
    const double error_there =
        focal * (in_neighbour.head<2>() / in_neighbour.z() - k.ray(there).head<2>()).norm();
    if (error_there > options.max_reprojection_px) continue;
    // The depth's spread from keypoint noise in both images, by finite differences.
    double variance = 0.0;
    bool stable = true;
    for (int coordinate = 0; coordinate < 4 && stable; ++coordinate) {
      cv::Point2f moved_here = here;
      cv::Point2f moved_there = there;
      float& moved = coordinate == 0   ? moved_here.x
                     : coordinate == 1 ? moved_here.y
                     : coordinate == 2 ? moved_there.x
                                       : moved_there.y;
      moved += static_cast<float>(pixel_step);
      const double moved_depth = depthAlongRay(k.ray(moved_here), rotation * k.ray(moved_there));
      stable = std::isfinite(moved_depth);
      const double derivative = (moved_depth - depth) / pixel_step;
      variance += derivative * derivative;
    }
    if (!stable) continue;
    const double depth_sd = std::sqrt(variance) * verification.keypoint_sigma_px;
    const auto index = static_cast<size_t>(keyframe_index);
    if (keyframe->depth_sd[index] <= depth_sd) continue;  // An earlier view did better.
    keyframe->points3d[index] =
        cv::Point3f(static_cast<float>(point.x()), static_cast<float>(point.y()),
                    static_cast<float>(point.z()));
    keyframe->depth_sd[index] = static_cast<float>(depth_sd);
    ++found;
  }
  return found;
}

int keypointsFromDepth(const cv::Mat& depth, const CameraIntrinsics& intrinsics,
                       const MetricPoseOptions& options, LocalFeatures* keyframe) {
  resetPoints(keyframe);
  if (depth.empty() || depth.channels() != 1 ||
      (depth.depth() != CV_16U && depth.depth() != CV_32F) || !intrinsics.valid() ||
      keyframe->image_size.area() == 0) {
    return 0;
  }
  const CameraIntrinsics k = intrinsics.scaledTo(keyframe->image_size);
  const double sx = static_cast<double>(depth.cols) / keyframe->image_size.width;
  const double sy = static_cast<double>(depth.rows) / keyframe->image_size.height;
  const double quantum = depth.depth() == CV_16U ? options.depth_image_metres_per_unit : 0.0;
  // Keypoints are lens-corrected (LoopDetector::makeKeyframe); the depth image is not.
  const std::vector<cv::Point2f> seen_at = k.imagePixels(keyframe->points);
  int found = 0;
  for (size_t i = 0; i < keyframe->points.size(); ++i) {
    const cv::Point2f& p = keyframe->points[i];
    // Pixel centres scale as (x + 0.5): the same convention as CameraIntrinsics::scaledTo.
    const int col = static_cast<int>(std::floor((seen_at[i].x + 0.5) * sx));
    const int row = static_cast<int>(std::floor((seen_at[i].y + 0.5) * sy));
    if (col < 0 || row < 0 || col >= depth.cols || row >= depth.rows) continue;
    const double z = depth.depth() == CV_16U
                         ? depth.at<uint16_t>(row, col) * options.depth_image_metres_per_unit
                         : static_cast<double>(depth.at<float>(row, col));
    if (!(z > 0.0 && z <= options.max_point_depth_m)) continue;
    const Eigen::Vector3d point = z * k.ray(p);
    keyframe->points3d[i] = cv::Point3f(static_cast<float>(point.x()),
                                        static_cast<float>(point.y()), static_cast<float>(z));
    // Along the ray (z scaled to the ray's length), from the sensor's noise model.
    const double z_sd =
        std::hypot(options.depth_image_sd_per_m2 * z * z, quantum / std::sqrt(12.0));
    keyframe->depth_sd[i] = static_cast<float>(z_sd * point.norm() / z);
    ++found;
  }
  return found;
}

MetricPoseResult estimateMetricPose(const LocalFeatures& query, const LocalFeatures& match,
                                    const std::vector<std::pair<int, int>>& matches,
                                    const CameraIntrinsics& intrinsics,
                                    const VerificationOptions& verification,
                                    const MetricPoseOptions& options) {
  MetricPoseResult result;
  if (!intrinsics.valid() || match.points3d.size() != match.points.size() ||
      match.depth_sd.size() != match.points.size()) {
    result.failure = "the match keyframe has no depths";
    return result;
  }
  const CameraIntrinsics k = intrinsics.scaledTo(query.image_size);
  const double focal = 0.5 * (k.fx + k.fy);
  const double keypoint_sd = std::max(verification.keypoint_sigma_px, 0.1);
  PnpProblem all;
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
  std::vector<std::pair<cv::Point2f, cv::Point2f>> pixel_pairs;
  for (const auto& [query_index, match_index] : matches) {
    const auto m = static_cast<size_t>(match_index);
    const cv::Point3f& point = match.points3d.at(m);
    if (!finite(point) || !std::isfinite(match.depth_sd[m])) continue;
    const cv::Point2f& pixel = query.points.at(static_cast<size_t>(query_index));
    object.push_back(point);
    image.push_back(pixel);
    pixel_pairs.emplace_back(pixel, match.points[m]);
    all.object.emplace_back(point.x, point.y, point.z);
    all.covariance.push_back(
        pointCovariance(all.object.back(), match.depth_sd[m], focal, keypoint_sd));
    all.pixel.emplace_back(pixel.x, pixel.y);
  }
  result.candidates = static_cast<int>(object.size());
  if (result.candidates < options.min_inliers) {
    result.failure = "only " + std::to_string(result.candidates) + " matches have a depth";
    return result;
  }

  cv::Mat rvec;
  cv::Mat tvec;
  std::vector<int> ransac_inliers;
  const bool solved = cv::solvePnPRansac(
      object, image, cv::Mat(k.matrix()), cv::noArray(), rvec, tvec, false, 300,
      static_cast<float>(options.max_reprojection_px), 0.999, ransac_inliers, cv::SOLVEPNP_SQPNP);
  if (!solved || static_cast<int>(ransac_inliers.size()) < options.min_inliers) {
    result.failure = "too few PnP inliers (" + std::to_string(ransac_inliers.size()) + ")";
    return result;
  }
  cv::Mat rotation_cv;
  cv::Rodrigues(rvec, rotation_cv);
  RelativePose pose;
  pose.metric = true;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) pose.rotation(r, c) = rotation_cv.at<double>(r, c);
    pose.translation(r) = tvec.at<double>(r);
  }

  // Refit on the inliers, weighting each by its expected error, and take again every point the
  // refitted pose explains, until the set stops changing.
  std::vector<size_t> chosen(ransac_inliers.begin(), ransac_inliers.end());
  double scale = 1.0;
  for (int round = 0; round < kMaxPnpRefitRounds; ++round) {
    updateWhiteners(pose, k, keypoint_sd, &all);
    refine(subset(all, chosen), k, &pose);
    updateWhiteners(pose, k, keypoint_sd, &all);
    scale = noiseScale(subset(all, chosen), pose, k);
    std::vector<size_t> again = selectInliers(all, pose, k, scale);
    if (again == chosen || static_cast<int>(again.size()) < options.min_inliers) break;
    chosen = std::move(again);
  }
  result.inliers = static_cast<int>(chosen.size());
  if (result.inliers < options.min_inliers) {
    result.failure = "too few PnP inliers (" + std::to_string(result.inliers) + ")";
    return result;
  }
  const PnpProblem inliers = subset(all, chosen);
  const Eigen::VectorXd pixel_errors = pixelErrors(inliers, pose, k);
  result.rms_error_px =
      std::sqrt(pixel_errors.squaredNorm() / static_cast<double>(inliers.object.size()));
  const Eigen::VectorXd r = residuals(inliers, pose, k);
  const Eigen::MatrixXd j = jacobian(inliers, pose, k);
  const Eigen::Matrix<double, 6, 6> information = j.transpose() * j;
  const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(information);
  if (!lu.isInvertible()) {
    result.failure = "degenerate point layout";
    return result;
  }
  // Residuals are whitened by the keypoint noise and each point's depth uncertainty; when they
  // spread wider than that, the covariance grows with them.
  const double variance_factor = std::max(1.0, r.squaredNorm() / static_cast<double>(r.size() - 6));
  pose.covariance = variance_factor * lu.inverse();
  result.pose = pose;
  for (const size_t i : chosen) result.inlier_pairs.push_back(pixel_pairs[i]);
  const double translation_sd = std::sqrt(pose.covariance.block<3, 3>(0, 0).trace());
  const double rotation_sd_deg =
      std::sqrt(pose.covariance.block<3, 3>(3, 3).trace()) / kDegreesToRadians;
  if (translation_sd > options.max_translation_sd_m ||
      rotation_sd_deg > options.max_rotation_sd_deg) {
    std::ostringstream failure;
    failure.precision(3);
    failure << "metric pose too uncertain (translation sd " << translation_sd << " m, rotation sd "
            << rotation_sd_deg << " deg)";
    result.failure = failure.str();
    return result;
  }
  result.found = true;
  return result;
}

RelativePose inBodyFrames(const RelativePose& in_cameras, const Pose& query_mount,
                          const Pose& match_mount) {
  Eigen::Isometry3d camera_loop = Eigen::Isometry3d::Identity();
  camera_loop.linear() = in_cameras.rotation;
  camera_loop.translation() = in_cameras.translation;
  const BodyLoop body = loopBetweenBodies(camera_loop, in_cameras.covariance,
                                          query_mount.toIsometry(), match_mount.toIsometry());
  RelativePose in_bodies = in_cameras;
  in_bodies.rotation = body.query_T_match.rotation();
  in_bodies.translation = body.query_T_match.translation();
  in_bodies.covariance = body.covariance;
  return in_bodies;
}

RelativePose inBodyFrame(const RelativePose& in_camera, const Pose& camera_mount) {
  return inBodyFrames(in_camera, camera_mount, camera_mount);
}

}  // namespace landmark_loop_closure
