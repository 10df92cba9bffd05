#include "landmark_loop_closure/sim/corridor_world.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace landmark_loop_closure {
namespace sim {

namespace {

constexpr double kWallSampleStep = 0.25;  // Metres between wall vertices; arcs need it.

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

uint32_t hash2(int x, int y, uint32_t seed) {
  uint32_t h = seed * 0x9E3779B9u ^ static_cast<uint32_t>(x) * 0x85EBCA6Bu ^
               static_cast<uint32_t>(y) * 0xC2B2AE35u;
  h ^= h >> 15;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12;
  return h;
}

/// The floor's grey at `point`: tiles of 0.6 m with a shade each and dark grout.
double floorGrey(const Eigen::Vector2d& point, uint32_t seed) {
  constexpr double kTile = 0.6;
  const double fx = point.x() / kTile;
  const double fy = point.y() / kTile;
  const int ix = static_cast<int>(std::floor(fx));
  const int iy = static_cast<int>(std::floor(fy));
  const bool grout = fx - ix < 0.05 || fy - iy < 0.05;
  return grout ? 70.0 : 85.0 + hash2(ix, iy, seed) % 20;
}

// A poster: a framed rectangle with one of a few inner patterns, drawn into the wall texture.
void drawPoster(cv::Mat* texture, const cv::Rect& box, cv::RNG* rng) {
  const int background = rng->uniform(20, 235);
  const int foreground = (background + rng->uniform(70, 160)) % 256;
  cv::Mat patch = (*texture)(box);
  patch.setTo(cv::Scalar(background));
  switch (rng->uniform(0, 4)) {
    case 0: {  // Stripes at a random angle.
      const double angle = rng->uniform(0.0, M_PI);
      const int period = rng->uniform(6, 20);
      for (int y = 0; y < patch.rows; ++y) {
        for (int x = 0; x < patch.cols; ++x) {
          const double t = x * std::cos(angle) + y * std::sin(angle);
          if (static_cast<int>(std::floor(t / period)) % 2 == 0) patch.at<uchar>(y, x) = foreground;
        }
      }
      break;
    }
    case 1: {  // Discs.
      const int count = rng->uniform(2, 7);
      for (int i = 0; i < count; ++i) {
        cv::circle(patch, cv::Point(rng->uniform(0, patch.cols), rng->uniform(0, patch.rows)),
                   rng->uniform(4, std::max(5, patch.rows / 3)), cv::Scalar(foreground), cv::FILLED,
                   cv::LINE_AA);
      }
      break;
    }
    case 2: {  // Checkerboard.
      const int cell = rng->uniform(6, 16);
      for (int y = 0; y < patch.rows; ++y) {
        for (int x = 0; x < patch.cols; ++x) {
          if (((x / cell) + (y / cell)) % 2 == 0) patch.at<uchar>(y, x) = foreground;
        }
      }
      break;
    }
    default: {  // Lines of "text": short dark blocks.
      for (int y = 6; y + 6 < patch.rows; y += 10) {
        for (int x = 6; x + 6 < patch.cols;) {
          const int word = rng->uniform(5, 25);
          cv::rectangle(patch, cv::Rect(x, y, std::min(word, patch.cols - 6 - x), 5),
                        cv::Scalar(foreground), cv::FILLED);
          x += word + rng->uniform(3, 8);
        }
      }
      break;
    }
  }
  cv::rectangle(*texture, box, cv::Scalar(rng->uniform(0, 60)), 3);
}

}  // namespace

CorridorWorld::CorridorWorld(const Options& options) : options_(options) {
  const double straight_x = options.length - 2.0 * options.corner_radius;
  const double straight_y = options.width - 2.0 * options.corner_radius;
  centre_length_ = 2.0 * (straight_x + straight_y) + 2.0 * M_PI * options.corner_radius;
  buildWall(0, 0.5 * options.corridor_width);   // Inner wall, left of the direction of travel.
  buildWall(1, -0.5 * options.corridor_width);  // Outer wall.

  // Perceptual aliasing on purpose: a few posters appear again elsewhere on the route.
  cv::RNG rng(options.seed * 31u + 5u);
  const int poster_w = static_cast<int>(1.0 * options.pixels_per_metre);
  const int poster_h = static_cast<int>(0.7 * options.pixels_per_metre);
  for (int copy = 0; copy < 3; ++copy) {
    const cv::Mat& source = wall_textures_[copy % 2];
    cv::Mat& target = wall_textures_[(copy + 1) % 2];
    const int sx = rng.uniform(0, source.cols - poster_w);
    const int tx = rng.uniform(0, target.cols - poster_w);
    const int y = static_cast<int>(0.6 * options.pixels_per_metre);
    source(cv::Rect(sx, y, poster_w, poster_h)).copyTo(target(cv::Rect(tx, y, poster_w, poster_h)));
  }
}

Eigen::Vector2d CorridorWorld::centreAt(double s, Eigen::Vector2d* tangent) const {
  const double half_x = 0.5 * options_.length;
  const double half_y = 0.5 * options_.width;
  const double r = options_.corner_radius;
  const double straight_x = options_.length - 2.0 * r;
  const double straight_y = options_.width - 2.0 * r;
  const double arc = 0.5 * M_PI * r;
  s = std::fmod(s, centre_length_);
  if (s < 0.0) s += centre_length_;

  // Counter-clockwise: bottom edge (+x), corner, right edge (+y), corner, top (-x), corner,
  // left (-y), corner.
  const double straights[4] = {straight_x, straight_y, straight_x, straight_y};
  const Eigen::Vector2d starts[4] = {
      {-half_x + r, -half_y}, {half_x, -half_y + r}, {half_x - r, half_y}, {-half_x, half_y - r}};
  const Eigen::Vector2d directions[4] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
  for (int side = 0; side < 4; ++side) {
    if (s <= straights[side]) {
      *tangent = directions[side];
      return starts[side] + s * directions[side];
    }
    s -= straights[side];
    if (s <= arc || side == 3) {
      const Eigen::Vector2d end = starts[side] + straights[side] * directions[side];
      const Eigen::Vector2d left(-directions[side].y(), directions[side].x());
      const Eigen::Vector2d centre = end + r * left;
      const double start_angle = std::atan2(-left.y(), -left.x());
      const double angle = start_angle + std::min(s, arc) / r;
      *tangent = Eigen::Vector2d(-std::sin(angle), std::cos(angle));
      return centre + r * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    }
    s -= arc;
  }
  *tangent = directions[0];
  return starts[0];
}

Pose2D CorridorWorld::poseAt(double s, double lateral) const {
  Eigen::Vector2d tangent;
  const Eigen::Vector2d centre = centreAt(s, &tangent);
  const Eigen::Vector2d left(-tangent.y(), tangent.x());
  const Eigen::Vector2d position = centre + lateral * left;
  return {position.x(), position.y(), std::atan2(tangent.y(), tangent.x())};
}

void CorridorWorld::buildWall(int wall, double offset) {
  const int samples = static_cast<int>(std::ceil(centre_length_ / kWallSampleStep));
  std::vector<Eigen::Vector2d> points;
  for (int i = 0; i <= samples; ++i) {
    Eigen::Vector2d tangent;
    const Eigen::Vector2d centre = centreAt(i * centre_length_ / samples, &tangent);
    points.push_back(centre + offset * Eigen::Vector2d(-tangent.y(), tangent.x()));
  }
  double u = 0.0;
  for (size_t i = 0; i + 1 < points.size(); ++i) {
    segments_.push_back({points[i], points[i + 1], wall, u});
    u += (points[i + 1] - points[i]).norm();
  }

  const double ppm = options_.pixels_per_metre;
  const int cols = static_cast<int>(std::ceil(u * ppm)) + 1;
  const int rows = static_cast<int>(std::ceil(options_.wall_height * ppm));
  if (options_.bay_length > 0.0) {
    if (static_cast<int>(wall_textures_.size()) <= wall) wall_textures_.resize(wall + 1);
    wall_textures_[wall] = bayTexture(wall, cols, rows);
    return;
  }
  cv::RNG rng(options_.seed * 977u + static_cast<uint32_t>(wall) * 131u + 1u);

  // Base: smooth low-frequency shading, so blank wall is not perfectly flat.
  cv::Mat coarse(std::max(2, rows / 40), std::max(2, cols / 40), CV_8UC1);
  rng.fill(coarse, cv::RNG::UNIFORM, 95, 165);
  cv::Mat texture;
  cv::resize(coarse, texture, cv::Size(cols, rows), 0, 0, cv::INTER_CUBIC);
  // Painted sections a few metres long, each its own shade, as in real buildings: they make
  // places tell apart at a glance.
  for (double start = 0.0; start < u;) {
    const double length = rng.uniform(2.5, 6.0);
    const cv::Rect section(static_cast<int>(start * ppm), 0, static_cast<int>(length * ppm) + 1,
                           rows);
    texture(section & cv::Rect(0, 0, cols, rows)) += cv::Scalar(rng.uniform(-70, 70));
    start += length;
  }

  // Skirting board and a dado rail: long horizontal edges, as in real corridors.
  cv::rectangle(texture, cv::Rect(0, rows - static_cast<int>(0.12 * ppm), cols, rows),
                cv::Scalar(50), cv::FILLED);
  cv::line(texture, cv::Point(0, static_cast<int>(0.45 * rows)),
           cv::Point(cols, static_cast<int>(0.45 * rows)), cv::Scalar(70), 2);

  // Doors, pillars and posters along the wall, spaced irregularly.
  for (double x = 0.5; x < u - 1.5;) {
    const int kind = rng.uniform(0, 10);
    const int left = static_cast<int>(x * ppm);
    if (kind < 2) {  // Door with a handle.
      const int w = static_cast<int>(0.9 * ppm);
      const int h = static_cast<int>(2.1 * ppm);
      cv::rectangle(texture, cv::Rect(left, rows - h, w, h), cv::Scalar(rng.uniform(30, 90)),
                    cv::FILLED);
      cv::rectangle(texture, cv::Rect(left, rows - h, w, h), cv::Scalar(15), 3);
      cv::circle(texture, cv::Point(left + w - 12, rows - h / 2), 4, cv::Scalar(220), cv::FILLED);
      x += 0.9 + rng.uniform(0.3, 1.2);
    } else if (kind < 3) {  // Pillar.
      const int w = static_cast<int>(rng.uniform(0.2, 0.4) * ppm);
      cv::rectangle(texture, cv::Rect(left, 0, w, rows), cv::Scalar(rng.uniform(170, 230)),
                    cv::FILLED);
      x += 0.4 + rng.uniform(0.4, 1.0);
    } else {  // Poster.
      const int w = static_cast<int>(rng.uniform(0.6, 1.6) * ppm);
      const int h = static_cast<int>(rng.uniform(0.5, 1.1) * ppm);
      const int top = static_cast<int>(rng.uniform(0.35, 1.0) * ppm);
      drawPoster(&texture, cv::Rect(left, top, std::min(w, cols - left - 1), h), &rng);
      x += w / ppm + rng.uniform(0.2, 0.9);
    }
  }
  if (static_cast<int>(wall_textures_.size()) <= wall) wall_textures_.resize(wall + 1);
  wall_textures_[wall] = texture;
}

cv::Mat CorridorWorld::bayTexture(int wall, int cols, int rows) const {
  const double ppm = options_.pixels_per_metre;
  const auto px = [ppm](double metres) { return static_cast<int>(metres * ppm); };
  const int bay_cols = std::max(px(2.0), px(options_.bay_length));
  cv::RNG rng(options_.seed * 613u + static_cast<uint32_t>(wall) * 17u + 3u);
  // One bay: green wall, a door, four lockers with vents, a notice board with its papers.
  cv::Mat bay(rows, bay_cols, CV_8UC1, cv::Scalar(120));
  const int door_left = px(0.3);
  const cv::Rect door(door_left, rows - px(2.1), px(0.9), px(2.1));
  cv::rectangle(bay, door, cv::Scalar(70), cv::FILLED);
  cv::rectangle(bay, door, cv::Scalar(20), 3);
  cv::rectangle(bay, cv::Rect(door_left + px(0.2), rows - px(1.9), px(0.5), px(0.5)),
                cv::Scalar(200), cv::FILLED);  // The door's window.
  cv::circle(bay, cv::Point(door_left + px(0.8), rows - px(1.0)), 4, cv::Scalar(220), cv::FILLED);
  for (int locker = 0; locker < 4; ++locker) {
    const cv::Rect box(px(1.5) + locker * px(0.42), rows - px(1.9), px(0.4), px(1.8));
    if (box.br().x >= bay_cols) break;
    cv::rectangle(bay, box, cv::Scalar(175), cv::FILLED);
    cv::rectangle(bay, box, cv::Scalar(60), 2);
    for (int vent = 0; vent < 4; ++vent) {
      const int y = box.y + px(0.15) + vent * 6;
      cv::line(bay, cv::Point(box.x + 6, y), cv::Point(box.br().x - 6, y), cv::Scalar(90), 2);
    }
  }
  const cv::Rect board(px(3.3), px(0.8), px(0.5), px(0.6));
  if (board.br().x < bay_cols) {
    bay(board).setTo(cv::Scalar(95));
    for (int paper = 0; paper < 5; ++paper) {
      const cv::Rect sheet(board.x + rng.uniform(2, board.width - 14),
                           board.y + rng.uniform(2, board.height - 18), 12, 16);
      cv::rectangle(bay, sheet & board, cv::Scalar(235), cv::FILLED);
    }
    cv::rectangle(bay, board, cv::Scalar(40), 3);
  }
  cv::rectangle(bay, cv::Rect(0, rows - px(0.12), bay_cols, px(0.12)), cv::Scalar(50), cv::FILLED);
  cv::line(bay, cv::Point(0, static_cast<int>(0.45 * rows)),
           cv::Point(bay_cols, static_cast<int>(0.45 * rows)), cv::Scalar(70), 2);
  // The wall: the bay again and again, each with its own room-number plate by the door.
  cv::Mat texture(rows, cols, CV_8UC1);
  for (int left = 0, number = 0; left < cols; left += bay_cols, ++number) {
    const int width = std::min(bay_cols, cols - left);
    bay(cv::Rect(0, 0, width, rows)).copyTo(texture(cv::Rect(left, 0, width, rows)));
    const cv::Rect plate(left + door_left + px(0.95), rows - px(1.6), px(0.15), px(0.1));
    if (plate.br().x >= cols) continue;
    texture(plate).setTo(cv::Scalar(230));
    for (int digit = 0; digit < 3; ++digit) {
      const int value = (number / (digit == 0 ? 1 : digit == 1 ? 10 : 100)) % 10;
      const int x = plate.x + 2 + digit * (plate.width - 4) / 3;
      cv::rectangle(texture, cv::Rect(x, plate.y + 2, 1 + value % 3, plate.height - 4),
                    cv::Scalar(20), cv::FILLED);
    }
  }
  // Light and wear vary a little along the wall.
  cv::Mat shading(std::max(2, rows / 40), std::max(2, cols / 40), CV_8UC1);
  rng.fill(shading, cv::RNG::UNIFORM, 118, 138);
  cv::resize(shading, shading, cv::Size(cols, rows), 0, 0, cv::INTER_CUBIC);
  cv::addWeighted(texture, 1.0, shading, 1.0, -128.0, texture);
  return texture;
}

namespace {

/// Where a ray first meets `segment`, if it does nearer than `hit`.
template <typename Segment, typename Hit>
void meet(const Eigen::Vector2d& origin, const Eigen::Vector2d& direction, const Segment& segment,
          Hit* hit) {
  const Eigen::Vector2d edge = segment.b - segment.a;
  const double denominator = cross2(direction, edge);
  if (std::abs(denominator) < 1e-12) return;
  const Eigen::Vector2d to_start = segment.a - origin;
  const double distance = cross2(to_start, edge) / denominator;
  const double along = cross2(to_start, direction) / denominator;
  if (distance > 1e-6 && along >= 0.0 && along <= 1.0 && distance < hit->distance) {
    *hit = {&segment, distance, segment.u_start + along * edge.norm()};
  }
}

}  // namespace

CorridorWorld::Hit CorridorWorld::castRayAmong(const Eigen::Vector2d& origin,
                                               const Eigen::Vector2d& direction,
                                               const std::vector<const Segment*>& segments) {
  Hit hit;
  hit.distance = std::numeric_limits<double>::infinity();
  for (const Segment* segment : segments) meet(origin, direction, *segment, &hit);
  return hit;
}

CorridorWorld::Hit CorridorWorld::castRay(const Eigen::Vector2d& origin,
                                          const Eigen::Vector2d& direction) const {
  Hit hit;
  hit.distance = std::numeric_limits<double>::infinity();
  for (const Segment& segment : segments_) meet(origin, direction, segment, &hit);
  return hit;
}

cv::Mat CorridorWorld::renderMounted(const Pose2D& pose, const CameraModel& camera,
                                     bool depth) const {
  cv::Mat image(camera.height, camera.width, depth ? CV_32FC1 : CV_8UC1);
  const double cx = 0.5 * (camera.width - 1);
  const double cy = 0.5 * (camera.height - 1);
  const Eigen::Vector2d heading(std::cos(pose.yaw), std::sin(pose.yaw));
  const Eigen::Vector2d left(-heading.y(), heading.x());
  const Eigen::Vector2d origin = Eigen::Vector2d(pose.x, pose.y) + camera.forward_m * heading;
  const double cos_pitch = std::cos(camera.pitch_rad), sin_pitch = std::sin(camera.pitch_rad);
  const double ppm = options_.pixels_per_metre;
  // A ray per pixel against every wall segment is slow: each segment is listed under the
  // directions (buckets of angle seen from the camera) it spans, and a ray meets only its
  // bucket's, which gives the same nearest hit.
  constexpr int kBuckets = 2048;
  const double bucket_width = 2.0 * M_PI / kBuckets;
  const auto bucket_of = [&](double angle) {
    const double wrapped = angle - 2.0 * M_PI * std::floor(angle / (2.0 * M_PI));
    return std::min(kBuckets - 1, static_cast<int>(wrapped / bucket_width));
  };
  std::vector<std::vector<const Segment*>> buckets(kBuckets);
  for (const Segment& segment : segments_) {
    const Eigen::Vector2d to_a = segment.a - origin, to_b = segment.b - origin;
    double start = std::atan2(to_a.y(), to_a.x());
    double span = std::atan2(to_b.y(), to_b.x()) - start;
    span -= 2.0 * M_PI * std::floor((span + M_PI) / (2.0 * M_PI));  // Into [-pi, pi).
    if (span < 0.0) {
      start += span;
      span = -span;
    }
    const int first = bucket_of(start);
    const int count = static_cast<int>(std::ceil(span / bucket_width)) + 1;
    for (int k = 0; k <= std::min(count, kBuckets - 1); ++k) {
      buckets[static_cast<size_t>((first + k) % kBuckets)].push_back(&segment);
    }
  }
  for (int row = 0; row < camera.height; ++row) {
    for (int col = 0; col < camera.width; ++col) {
      // The pixel's ray, optical depth 1, in the base frame (x ahead, y left, z up), the camera
      // pitched down about y.
      const double to_left = (cx - col) / camera.focal_px;
      const double up = (cy - row) / camera.focal_px;
      const double ahead = cos_pitch + up * sin_pitch;
      const double rise = -sin_pitch + up * cos_pitch;
      const Eigen::Vector2d flat = ahead * heading + to_left * left;
      const double flat_length = flat.norm();
      const Eigen::Vector2d direction = flat / flat_length;
      const Hit ray = castRayAmong(
          origin, direction,
          buckets[static_cast<size_t>(bucket_of(std::atan2(direction.y(), direction.x())))]);
      const double wall_z = camera.height_m + rise / flat_length * ray.distance;
      const bool wall = ray.segment && wall_z >= 0.0 && wall_z <= options_.wall_height;
      if (depth) {
        float value = 0.0f;  // The ceiling: nothing hit.
        if (wall) {
          value = static_cast<float>(ray.distance / flat_length);
        } else if (rise < 0.0) {
          value = static_cast<float>(camera.height_m / -rise);
        }
        image.at<float>(row, col) = value;
        continue;
      }
      double value = 200.0 - 0.2 * row;  // Ceiling.
      if (wall) {
        const cv::Mat& texture = wall_textures_[ray.segment->wall];
        const int tx = std::clamp(static_cast<int>(ray.u * ppm), 0, texture.cols - 1);
        const int ty = std::clamp(static_cast<int>((options_.wall_height - wall_z) * ppm), 0,
                                  texture.rows - 1);
        value = texture.at<uchar>(ty, tx);
      } else if (rise < 0.0) {  // Floor: tiles with per-tile shade and dark grout.
        const double ground = camera.height_m * flat_length / -rise;
        const Eigen::Vector2d point = origin + ground * direction;
        value = floorGrey(point, options_.seed);
      }
      image.at<uchar>(row, col) = cv::saturate_cast<uchar>(value);
    }
  }
  return image;
}

cv::Mat CorridorWorld::renderDepth(const Pose2D& pose, const CameraModel& camera) const {
  if (camera.forward_m != 0.0 || camera.pitch_rad != 0.0) return renderMounted(pose, camera, true);
  cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(0.0f));
  const double cx = 0.5 * (camera.width - 1);
  const double cy = 0.5 * (camera.height - 1);
  const Eigen::Vector2d origin(pose.x, pose.y);
  for (int col = 0; col < camera.width; ++col) {
    const double offset_angle = std::atan2(cx - col, camera.focal_px);
    const double angle = pose.yaw + offset_angle;
    const Hit ray = castRay(origin, Eigen::Vector2d(std::cos(angle), std::sin(angle)));
    const double wall_depth = ray.distance * std::cos(offset_angle);
    for (int row = 0; row < camera.height; ++row) {
      const double dy = row - cy;
      const double wall_z = camera.height_m - dy * wall_depth / camera.focal_px;
      if (ray.segment && wall_z >= 0.0 && wall_z <= options_.wall_height) {
        depth.at<float>(row, col) = static_cast<float>(wall_depth);
      } else if (dy > 0.0) {  // The floor, at optical depth height * f / dy.
        depth.at<float>(row, col) = static_cast<float>(camera.height_m * camera.focal_px / dy);
      }
    }
  }
  return depth;
}

cv::Mat CorridorWorld::render(const Pose2D& pose, const CameraModel& camera,
                              const Lighting& lighting, uint32_t noise_seed) const {
  const bool mounted = camera.forward_m != 0.0 || camera.pitch_rad != 0.0;
  cv::Mat image =
      mounted ? renderMounted(pose, camera, false) : cv::Mat(camera.height, camera.width, CV_8UC1);
  const double cx = 0.5 * (camera.width - 1);
  const double cy = 0.5 * (camera.height - 1);
  const double ppm = options_.pixels_per_metre;
  const Eigen::Vector2d origin(pose.x, pose.y);

  for (int col = 0; col < camera.width && !mounted; ++col) {
    const double offset_angle = std::atan2(cx - col, camera.focal_px);
    const double angle = pose.yaw + offset_angle;
    const Eigen::Vector2d direction(std::cos(angle), std::sin(angle));
    const Hit ray = castRay(origin, direction);
    const Segment* hit = ray.segment;
    const double hit_u = ray.u;
    const double cos_offset = std::cos(offset_angle);
    const double depth = ray.distance * cos_offset;  // Perpendicular distance: no fish-eye bend.
    for (int row = 0; row < camera.height; ++row) {
      const double dy = row - cy;
      double value = 200.0 - 0.2 * row;  // Ceiling.
      const double wall_z = camera.height_m - dy * depth / camera.focal_px;
      if (hit && wall_z >= 0.0 && wall_z <= options_.wall_height) {
        const cv::Mat& texture = wall_textures_[hit->wall];
        const int tx = std::clamp(static_cast<int>(hit_u * ppm), 0, texture.cols - 1);
        const int ty = std::clamp(static_cast<int>((options_.wall_height - wall_z) * ppm), 0,
                                  texture.rows - 1);
        value = texture.at<uchar>(ty, tx);
      } else if (dy > 0.0) {  // Floor: tiles with per-tile shade and dark grout.
        const double ground = camera.height_m * camera.focal_px / dy / cos_offset;
        const Eigen::Vector2d point = origin + ground * direction;
        value = floorGrey(point, options_.seed);
      }
      image.at<uchar>(row, col) = cv::saturate_cast<uchar>(value);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.0);  // Camera blur; hides sampling aliasing.
  cv::Mat lit;
  image.convertTo(lit, CV_32F, lighting.gain, lighting.offset);
  if (lighting.noise_sigma > 0.0) {
    cv::Mat noise(lit.size(), CV_32F);
    cv::RNG rng(noise_seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, lighting.noise_sigma);
    lit += noise;
  }
  lit.convertTo(image, CV_8U);
  return image;
}

}  // namespace sim
}  // namespace landmark_loop_closure
