#include "landmark_loop_closure/geometry/geometric_verification.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>

#include "landmark_loop_closure/common/image_helpers.h"
#include "landmark_loop_closure/geometry/pose.h"
#include "landmark_loop_closure/geometry/pose_jacobian.h"

namespace landmark_loop_closure {

namespace {

constexpr int kSpreadGrid = 4;
constexpr int kMaxModelRefitRounds = 5;
constexpr float kOrbScaleFactor = 1.2f;
constexpr double kRadiansToDegrees = 180.0 / M_PI;

// Signed Sampson distance of a correspondence to the epipolar geometry X_q = R X_m + t, on
// normalised image coordinates; multiplied by the focal length it is in pixels.
double sampson(const Eigen::Matrix3d& essential, const Eigen::Vector3d& query,
               const Eigen::Vector3d& match) {
  const Eigen::Vector3d line_in_query = essential * match;
  const Eigen::Vector3d line_in_match = essential.transpose() * query;
  const double denominator =
      line_in_query.head<2>().squaredNorm() + line_in_match.head<2>().squaredNorm();
  return denominator > 0.0 ? query.dot(line_in_query) / std::sqrt(denominator) : 0.0;
}

// Two unit vectors orthogonal to t (and to each other): the tangent space of the direction.
void tangentBasis(const Eigen::Vector3d& t, Eigen::Vector3d* b1, Eigen::Vector3d* b2) {
  const Eigen::Vector3d helper =
      std::abs(t.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  *b1 = t.cross(helper).normalized();
  *b2 = t.cross(*b1).normalized();
}

struct Correspondences {
  std::vector<Eigen::Vector3d> query;  // Normalised, z = 1.
  std::vector<Eigen::Vector3d> match;
};

using Parameters = Eigen::Matrix<double, 5, 1>;

// The pose moved by p = (two steps of the translation direction in its tangent plane; rotation
// vector applied on the left): pose_jacobian.h's order.
RelativePose perturbed(const RelativePose& pose, const Parameters& p) {
  Eigen::Vector3d b1;
  Eigen::Vector3d b2;
  tangentBasis(pose.translation, &b1, &b2);
  const Eigen::Vector3d rotation_vector = p.tail<3>();
  const double angle = rotation_vector.norm();
  const Eigen::Matrix3d increment =
      angle > 0.0 ? Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix()
                  : Eigen::Matrix3d::Identity();
  RelativePose moved = pose;
  moved.rotation = increment * pose.rotation;
  moved.translation = (pose.translation + p(0) * b1 + p(1) * b2).normalized();
  return moved;
}

// Residuals (pixels) of the pose moved by p.
Eigen::VectorXd residuals(const Correspondences& c, const RelativePose& pose, const Parameters& p,
                          double focal) {
  const RelativePose moved = perturbed(pose, p);
  const Eigen::Matrix3d essential = skew(moved.translation) * moved.rotation;
  Eigen::VectorXd r(static_cast<Eigen::Index>(c.query.size()));
  for (size_t i = 0; i < c.query.size(); ++i) {
    r(static_cast<Eigen::Index>(i)) = focal * sampson(essential, c.query[i], c.match[i]);
  }
  return r;
}

// Direction and rotation, or the rotation only (the direction held).
const std::vector<int>& freeParameters(bool rotation_only) {
  static const std::vector<int> all = allColumns(5);
  static const std::vector<int> rotation = {2, 3, 4};
  return rotation_only ? rotation : all;
}

Eigen::MatrixXd jacobian(const Correspondences& c, const RelativePose& pose, double focal,
                         bool rotation_only = false) {
  return poseJacobian(
      [&](const Eigen::VectorXd& p) { return residuals(c, pose, Parameters(p), focal); }, 5,
      freeParameters(rotation_only));
}

// Levenberg-Marquardt on the Sampson errors of the inliers, from the RANSAC solution (a minimal
// sample's pose, not the best fit to all inliers); `rotation_only` holds the direction.
void refine(const Correspondences& c, double focal, RelativePose* pose,
            bool rotation_only = false) {
  const std::vector<int>& free = freeParameters(rotation_only);
  double cost = residuals(c, *pose, Parameters::Zero(), focal).squaredNorm();
  double damping = 1e-3;
  for (int iteration = 0; iteration < 50 && damping < 1e8; ++iteration) {
    const Eigen::VectorXd r = residuals(c, *pose, Parameters::Zero(), focal);
    const Eigen::MatrixXd j = jacobian(c, *pose, focal, rotation_only);
    Eigen::MatrixXd a = j.transpose() * j;
    a.diagonal() *= 1.0 + damping;
    const Eigen::VectorXd solution = a.ldlt().solve(-j.transpose() * r);
    Parameters step = Parameters::Zero();
    for (size_t k = 0; k < free.size(); ++k) step(free[k]) = solution(static_cast<Eigen::Index>(k));
    const RelativePose candidate = perturbed(*pose, step);
    const double candidate_cost = residuals(c, candidate, Parameters::Zero(), focal).squaredNorm();
    if (candidate_cost < cost) {
      const bool converged = cost - candidate_cost < 1e-9 * cost;
      *pose = candidate;
      cost = candidate_cost;
      damping *= 0.1;
      if (converged) break;
    } else {
      damping *= 10.0;
    }
  }
}

Correspondences subset(const Correspondences& all, const std::vector<size_t>& indices) {
  Correspondences chosen;
  for (const size_t i : indices) {
    chosen.query.push_back(all.query[i]);
    chosen.match.push_back(all.match[i]);
  }
  return chosen;
}

// Depths along both rays of the point closest to them (midpoint triangulation); false when the
// rays are parallel.
bool depths(const RelativePose& pose, const Eigen::Vector3d& query, const Eigen::Vector3d& match,
            double* depth_query, double* depth_match) {
  // depth_query * query = depth_match * R * match + t, least squares in the two depths.
  Eigen::Matrix<double, 3, 2> a;
  a.col(0) = query;
  a.col(1) = -(pose.rotation * match);
  const Eigen::Matrix2d normal = a.transpose() * a;
  if (std::abs(normal.determinant()) < 1e-12 * normal.trace() * normal.trace()) return false;
  const Eigen::Vector2d d = normal.ldlt().solve(a.transpose() * pose.translation);
  *depth_query = d(0);
  *depth_match = d(1);
  return true;
}

// Matches within `threshold_px` (Sampson) of the pose's epipolar geometry whose point lies in
// front of both cameras; points too far to triangulate (parallel rays) count as in front.
std::vector<size_t> selectInliers(const Correspondences& all, const RelativePose& pose,
                                  double focal, double threshold_px) {
  const Eigen::Matrix3d essential = skew(pose.translation) * pose.rotation;
  std::vector<size_t> chosen;
  for (size_t i = 0; i < all.query.size(); ++i) {
    if (std::abs(focal * sampson(essential, all.query[i], all.match[i])) > threshold_px) continue;
    double depth_query = 0.0;
    double depth_match = 0.0;
    if (depths(pose, all.query[i], all.match[i], &depth_query, &depth_match) &&
        (depth_query <= 0.0 || depth_match <= 0.0)) {
      continue;
    }
    chosen.push_back(i);
  }
  return chosen;
}

double cost(const Correspondences& c, const RelativePose& pose, double focal) {
  return residuals(c, pose, Parameters::Zero(), focal).squaredNorm();
}

// The sign of the translation the Sampson error cannot see: points in front of both cameras.
void orientTranslation(const Correspondences& c, RelativePose* pose) {
  int in_front = 0;
  int behind = 0;
  for (size_t i = 0; i < c.query.size(); ++i) {
    double depth_query = 0.0;
    double depth_match = 0.0;
    if (!depths(*pose, c.query[i], c.match[i], &depth_query, &depth_match)) continue;
    (depth_query > 0.0 && depth_match > 0.0 ? in_front : behind) += 1;
  }
  if (behind > in_front) pose->translation = -pose->translation;
}

struct ProfilePoint {
  RelativePose pose;
  double cost = 0.0;
};

// The cost profile over translation directions: for each of `directions` directions spread evenly
// over the half sphere around the estimate (t and -t give the same errors), the best rotation.
// Unlike a covariance at one minimum, it shows every direction the matches cannot rule out.
std::vector<ProfilePoint> directionProfile(const Correspondences& c, double focal,
                                           const RelativePose& best, int directions) {
  std::vector<ProfilePoint> profile;
  const double golden_angle = M_PI * (3.0 - std::sqrt(5.0));
  const int sphere_points = 2 * directions;
  for (int i = 0; i < sphere_points; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / sphere_points;
    const double radius = std::sqrt(std::max(0.0, 1.0 - z * z));
    const Eigen::Vector3d direction(radius * std::cos(golden_angle * i),
                                    radius * std::sin(golden_angle * i), z);
    if (direction.dot(best.translation) < 0.0) continue;
    ProfilePoint point;
    point.pose = best;
    point.pose.translation = direction;
    refine(c, focal, &point.pose, /*rotation_only=*/true);
    point.cost = cost(c, point.pose, focal);
    profile.push_back(point);
  }
  return profile;
}

Eigen::Matrix<double, 6, 1> difference(const RelativePose& a, const RelativePose& b) {
  Eigen::Matrix<double, 6, 1> d;
  // In the tangent plane of b's direction: a unit direction has no variance along itself.
  const Eigen::Matrix3d tangent =
      Eigen::Matrix3d::Identity() - b.translation * b.translation.transpose();
  d.head<3>() = tangent * (a.translation - b.translation);
  const Eigen::AngleAxisd rotation(a.rotation * b.rotation.transpose());
  d.tail<3>() = rotation.angle() * rotation.axis();
  return d;
}

// sigma^2 (J^T J)^-1 over (direction, rotation), mapped to x, y, z, rx, ry, rz. False when the
// problem is degenerate.
bool estimateCovariance(const Correspondences& c, double focal, double min_sigma_px,
                        RelativePose* pose, double* rms_px) {
  const Eigen::Matrix<double, 5, 1> zero = Eigen::Matrix<double, 5, 1>::Zero();
  const Eigen::VectorXd r0 = residuals(c, *pose, zero, focal);
  const Eigen::Index n = r0.size();
  *rms_px = std::sqrt(r0.squaredNorm() / std::max<Eigen::Index>(1, n));
  if (n <= 5) return false;
  const Eigen::MatrixXd j = jacobian(c, *pose, focal);
  const Eigen::Matrix<double, 5, 5> information = j.transpose() * j;
  const Eigen::FullPivLU<Eigen::Matrix<double, 5, 5>> lu(information);
  if (!lu.isInvertible()) return false;
  const double sigma_squared =
      std::max(r0.squaredNorm() / static_cast<double>(n - 5), min_sigma_px * min_sigma_px);
  const Eigen::Matrix<double, 5, 5> covariance = sigma_squared * lu.inverse();
  Eigen::Vector3d b1;
  Eigen::Vector3d b2;
  tangentBasis(pose->translation, &b1, &b2);
  Eigen::Matrix<double, 3, 2> basis;
  basis << b1, b2;
  // Parameters -> message order: translation = basis * direction increments; rotation as is.
  Eigen::Matrix<double, 6, 5> map = Eigen::Matrix<double, 6, 5>::Zero();
  map.block<3, 2>(0, 0) = basis;
  map.block<3, 3>(3, 2) = Eigen::Matrix3d::Identity();
  pose->covariance = map * covariance * map.transpose();
  return true;
}

}  // namespace

RelativePose withUnknownScale(RelativePose pose) {
  if (pose.metric || !(pose.translation.norm() > 0.0)) return pose;
  const Eigen::Vector3d direction = pose.translation.normalized();
  pose.covariance.block<3, 3>(0, 0) += kUnknownScaleVariance * direction * direction.transpose();
  return pose;
}

size_t LocalFeatures::bytes() const {
  return points.size() * sizeof(cv::Point2f) + descriptors.total() * descriptors.elemSize() +
         points3d.size() * sizeof(cv::Point3f) + depth_sd.size() * sizeof(float);
}

const ParameterTable<VerificationOptions>& VerificationOptions::parameters() {
  using O = VerificationOptions;
  static const auto table =
      ParameterTable<O>("advanced/verification/",
                        "geometric verification: a loop must also agree on geometry.")
          .flag("enabled", &O::enabled,
                "ORB keypoints per keyframe (~13 KB); a loop needs enough well-spread matches "
                "that agree with one essential matrix (RANSAC, camera_info's K), else it is "
                "refused as geometry_rejected.")
          .flag("required", &O::required,
                "true: refuse loops that cannot be checked (no camera_info yet); false: publish "
                "them unverified (verified and has_relative_pose false).")
          .flag("publish_scale_free_pose", &O::publish_scale_free_pose,
                "monocular poses (rotation + unit direction) go out with has_relative_pose true. "
                "Off by default: on generated pairs about one in four accepted poses is further "
                "off than its covariance says (README).")
          .integer("max_image_width", &O::max_image_width, between(64, 8192),
                   "keypoints are found on the image shrunk to at most this width.")
          .evaluationOnly()
          .integer("max_features", &O::max_features, between(8, 10000),
                   "ORB keypoints kept per keyframe.")
          .number("ratio_test", &O::ratio_test, openBetween(0, 1, true, false),
                  "a keypoint match needs best / second-best Hamming distance below this.")
          .evaluationOnly()
          .number("ransac_threshold_px", &O::ransac_threshold_px, above(0),
                  "RANSAC inlier threshold, pixels.")
          .evaluationOnly()
          .integer("min_inliers", &O::min_inliers, between(8, 10000),
                   "fewer geometric inliers: the loop is refused.")
          .number("min_spread", &O::min_spread, between(0, 1),
                  "share of a 4x4 grid over the query image that must hold inliers.")
          .number("min_parallax_deg", &O::min_parallax_deg, openBetween(0, 90, false, true),
                  "median ray angle after rotation; below it (pure rotation) the translation is "
                  "undefined: the place is confirmed, without a pose.")
          .evaluationOnly()
          .integer("orb_levels", &O::orb_levels, between(1, 8),
                   "ORB pyramid levels (scale 1.2); keypoints of coarser levels sit up to a pixel "
                   "off, which skews the pose, and revisits are seen at similar scale.")
          .evaluationOnly()
          .integer("ambiguity_directions", &O::ambiguity_directions, between(0, 100000),
                   "translation directions over the half sphere where the best rotation is "
                   "fitted: directions the matches cannot rule out widen the covariance.")
          .evaluationOnly()
          .number("keypoint_sigma_px", &O::keypoint_sigma_px, atLeast(0),
                  "keypoint noise assumed at least (pixels) in the covariance and that test.")
          .evaluationOnly()
          .number("max_rotation_sd_deg", &O::max_rotation_sd_deg, above(0),
                  "larger rotation uncertainty: refused as \"pose ambiguous\".")
          .evaluationOnly()
          .number("max_direction_sd_deg", &O::max_direction_sd_deg, above(0),
                  "larger translation-direction uncertainty: refused the same way.")
          .evaluationOnly();
  return table;
}

std::string VerificationOptions::validate() const { return parameters().check(*this); }

const char* toString(VerificationVerdict verdict) {
  switch (verdict) {
    case VerificationVerdict::kAccepted:
      return "verified";
    case VerificationVerdict::kNoIntrinsics:
      return "no camera intrinsics";
    case VerificationVerdict::kTooFewFeatures:
      return "too few keypoints (no texture?)";
    case VerificationVerdict::kTooFewMatches:
      return "too few keypoint matches";
    case VerificationVerdict::kTooFewInliers:
      return "too few geometric inliers";
    case VerificationVerdict::kInliersClustered:
      return "inliers bunched in a small part of the image";
    case VerificationVerdict::kNoParallax:
      return "no parallax (pure rotation or distant scene)";
    case VerificationVerdict::kAmbiguous:
      return "pose ambiguous (resampled matches disagree)";
  }
  return "unknown";
}

std::vector<std::pair<int, int>> ratioTestMatches(const LocalFeatures& query,
                                                  const LocalFeatures& match, double ratio_test) {
  std::vector<std::pair<int, int>> matches;
  if (query.descriptors.empty() || match.descriptors.empty()) return matches;
  std::vector<std::vector<cv::DMatch>> knn;
  cv::BFMatcher(cv::NORM_HAMMING).knnMatch(query.descriptors, match.descriptors, knn, 2);
  std::vector<cv::DMatch> best_for_match(static_cast<size_t>(match.descriptors.rows),
                                         cv::DMatch(-1, -1, 1e9f));
  for (const std::vector<cv::DMatch>& pair : knn) {
    if (pair.size() < 2 || pair[0].distance > ratio_test * pair[1].distance) continue;
    cv::DMatch& best = best_for_match[static_cast<size_t>(pair[0].trainIdx)];
    if (pair[0].distance < best.distance) best = pair[0];
  }
  for (const cv::DMatch& m : best_for_match) {
    if (m.queryIdx >= 0) matches.emplace_back(m.queryIdx, m.trainIdx);
  }
  return matches;
}

GeometricVerifier::GeometricVerifier(const VerificationOptions& options) : options_(options) {}

LocalFeatures GeometricVerifier::extract(const cv::Mat& image) const {
  LocalFeatures features;
  features.image_size = image.size();
  if (image.empty() || image.type() != CV_8UC1) return features;
  // A detector per call: cv::ORB keeps state and is not documented as safe to share.
  const cv::Ptr<cv::ORB> orb =
      cv::ORB::create(options_.max_features, kOrbScaleFactor, options_.orb_levels);
  std::vector<cv::KeyPoint> keypoints;
  orb->detectAndCompute(image, cv::noArray(), keypoints, features.descriptors);
  features.points.reserve(keypoints.size());
  for (const cv::KeyPoint& keypoint : keypoints) features.points.push_back(keypoint.pt);
  return features;
}

LocalFeatures GeometricVerifier::extractKeyframe(const cv::Mat& image,
                                                 const CameraIntrinsics& intrinsics) const {
  if (image.empty()) return extract(image);
  const int width = std::min(image.cols, options_.max_image_width);
  const int height = std::max(
      1, static_cast<int>(std::lround(static_cast<double>(image.rows) * width / image.cols)));
  LocalFeatures features = extract(toWorkingImage(image, width, height));
  // The lens is corrected once, here: a stored keyframe keeps the calibration it was taken with.
  if (intrinsics.distorted() && intrinsics.valid()) {
    features.points = intrinsics.scaledTo(features.image_size).idealPixels(features.points);
  }
  return features;
}

VerificationResult GeometricVerifier::verify(const LocalFeatures& query, const LocalFeatures& match,
                                             const CameraIntrinsics& intrinsics) const {
  VerificationResult result;
  if (!intrinsics.valid() || query.image_size.area() == 0) return result;
  const CameraIntrinsics k = intrinsics.scaledTo(query.image_size);
  const int needed = options_.min_inliers;
  if (static_cast<int>(query.points.size()) < needed ||
      static_cast<int>(match.points.size()) < needed || match.image_size != query.image_size) {
    result.verdict = VerificationVerdict::kTooFewFeatures;
    return result;
  }

  std::vector<cv::Point2f> query_points;
  std::vector<cv::Point2f> match_points;
  for (const auto& [query_index, match_index] :
       ratioTestMatches(query, match, options_.ratio_test)) {
    query_points.push_back(query.points[static_cast<size_t>(query_index)]);
    match_points.push_back(match.points[static_cast<size_t>(match_index)]);
  }
  result.matches = static_cast<int>(query_points.size());
  if (result.matches < needed) {
    result.verdict = VerificationVerdict::kTooFewMatches;
    return result;
  }

  // Points of the match image are "camera 1", the query's "camera 2": recoverPose then gives
  // X_query = R X_match + t, i.e. T_query_match.
  cv::Mat inlier_mask;
  const cv::Mat camera(k.matrix());
  cv::Mat essential = cv::findEssentialMat(match_points, query_points, camera, cv::USAC_ACCURATE,
                                           0.999, options_.ransac_threshold_px, inlier_mask);
  result.verdict = VerificationVerdict::kTooFewInliers;
  if (essential.rows < 3 || essential.cols != 3) return result;
  essential = essential.rowRange(0, 3).clone();  // Several solutions: the first.
  cv::Mat rotation;
  cv::Mat translation;
  cv::recoverPose(essential, match_points, query_points, camera, rotation, translation,
                  inlier_mask);
  RelativePose pose;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) pose.rotation(r, c) = rotation.at<double>(r, c);
    pose.translation(r) = translation.at<double>(r);
  }
  pose.translation.normalize();

  // RANSAC's inliers are those of a minimal sample's pose: they lean towards it. Refit on them,
  // take again every match the refitted pose explains (in front of both cameras), until the set
  // stops changing, so the final pose is fitted to all matches it agrees with.
  Correspondences all;
  for (size_t i = 0; i < query_points.size(); ++i) {
    all.query.push_back(k.ray(query_points[i]));
    all.match.push_back(k.ray(match_points[i]));
  }
  const double focal = 0.5 * (k.fx + k.fy);
  std::vector<size_t> chosen = selectInliers(all, pose, focal, options_.ransac_threshold_px);
  for (int round = 0; round < kMaxModelRefitRounds && static_cast<int>(chosen.size()) >= needed;
       ++round) {
    refine(subset(all, chosen), focal, &pose);
    std::vector<size_t> again = selectInliers(all, pose, focal, options_.ransac_threshold_px);
    if (again == chosen) break;
    chosen = std::move(again);
  }
  result.inliers = static_cast<int>(chosen.size());
  if (result.inliers < needed) return result;
  const Correspondences inliers = subset(all, chosen);

  std::vector<bool> occupied(kSpreadGrid * kSpreadGrid, false);
  for (const size_t i : chosen) {
    const cv::Point2f& q = query_points[i];
    result.inlier_pairs.emplace_back(q, match_points[i]);
    const int gx = std::clamp(static_cast<int>(q.x * kSpreadGrid / query.image_size.width), 0,
                              kSpreadGrid - 1);
    const int gy = std::clamp(static_cast<int>(q.y * kSpreadGrid / query.image_size.height), 0,
                              kSpreadGrid - 1);
    occupied[static_cast<size_t>(gy * kSpreadGrid + gx)] = true;
  }
  result.spread =
      static_cast<double>(std::count(occupied.begin(), occupied.end(), true)) / occupied.size();
  if (result.spread < options_.min_spread) {
    result.verdict = VerificationVerdict::kInliersClustered;
    return result;
  }

  // The cost profile over translation directions: a lower point means the estimate sat in a
  // local minimum, so refit from there.
  double best_cost = cost(inliers, pose, focal);
  std::vector<ProfilePoint> profile;
  for (int pass = 0; pass < 2; ++pass) {
    profile = directionProfile(inliers, focal, pose, options_.ambiguity_directions);
    const auto lowest = std::min_element(
        profile.begin(), profile.end(),
        [](const ProfilePoint& a, const ProfilePoint& b) { return a.cost < b.cost; });
    if (lowest == profile.end() || lowest->cost >= best_cost - 1e-9) break;
    pose = lowest->pose;
    refine(inliers, focal, &pose);
    orientTranslation(inliers, &pose);
    best_cost = cost(inliers, pose, focal);
  }

  std::vector<double> angles;
  for (size_t i = 0; i < inliers.query.size(); ++i) {
    const Eigen::Vector3d rotated = (pose.rotation * inliers.match[i]).normalized();
    const double cosine = std::clamp(rotated.dot(inliers.query[i].normalized()), -1.0, 1.0);
    angles.push_back(std::acos(cosine) * kRadiansToDegrees);
  }
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
  result.parallax_deg = angles[angles.size() / 2];
  if (result.parallax_deg < options_.min_parallax_deg ||
      !estimateCovariance(inliers, focal, options_.keypoint_sigma_px, &pose,
                          &result.rms_error_px)) {
    result.verdict = VerificationVerdict::kNoParallax;
    return result;
  }
  // Directions the matches cannot tell apart from the best (a 99 % likelihood-ratio region over
  // the two direction parameters, keypoint noise at least keypoint_sigma_px) widen the
  // covariance by their spread: the linearisation at one minimum cannot see a second valley.
  constexpr double kChiSquared2Dof99 = 9.21;
  const double sigma_squared = std::max(best_cost / static_cast<double>(inliers.query.size() - 5),
                                        options_.keypoint_sigma_px * options_.keypoint_sigma_px);
  Eigen::Matrix<double, 6, 6> spread = Eigen::Matrix<double, 6, 6>::Zero();
  int plausible = 0;
  for (const ProfilePoint& point : profile) {
    if (point.cost - best_cost > kChiSquared2Dof99 * sigma_squared) continue;
    const Eigen::Matrix<double, 6, 1> d = difference(point.pose, pose);
    spread += d * d.transpose();
    ++plausible;
  }
  if (plausible > 0) pose.covariance += spread / static_cast<double>(plausible);
  result.rotation_sd_deg = std::sqrt(pose.covariance.block<3, 3>(3, 3).trace()) * kRadiansToDegrees;
  result.direction_sd_deg =
      std::sqrt(pose.covariance.block<3, 3>(0, 0).trace()) * kRadiansToDegrees;
  result.pose = pose;
  if (result.rotation_sd_deg > options_.max_rotation_sd_deg ||
      result.direction_sd_deg > options_.max_direction_sd_deg) {
    result.verdict = VerificationVerdict::kAmbiguous;
    return result;
  }
  result.verdict = VerificationVerdict::kAccepted;
  return result;
}

}  // namespace landmark_loop_closure
