#include "landmark_loop_closure/backend/pose_graph_file.h"

#include <cstdint>

#include "common/checksummed_file.h"
#include "common/little_endian.h"

namespace landmark_loop_closure {
namespace {

constexpr char kMagic[8] = {'L', 'L', 'C', 'P', 'G', 'R', 'A', 'F'};
constexpr uint32_t kVersion = 1;
constexpr uint32_t kKeyframe = 1;
constexpr uint32_t kLoop = 2;
// More would be a damaged count: a map of a million keyframes and as many loops is far below.
constexpr uint64_t kMaxInputs = 50000000;

void writePose(LittleEndianWriter* out, const Eigen::Vector3d& position,
               const Eigen::Quaterniond& orientation) {
  for (int k = 0; k < 3; ++k) out->f64(position[k]);
  for (int k = 0; k < 4; ++k) out->f64(orientation.coeffs()[k]);
}

// As written: the session checks what it is given (finite, unit quaternion), as for a message.
bool readPose(LittleEndianReader* in, Eigen::Vector3d* position, Eigen::Quaterniond* orientation) {
  for (int k = 0; k < 3; ++k) {
    if (!in->f64(&(*position)[k])) return false;
  }
  for (int k = 0; k < 4; ++k) {
    if (!in->f64(&orientation->coeffs()[k])) return false;
  }
  return true;
}

void writeKeyframe(LittleEndianWriter* out, const GraphKeyframe& keyframe) {
  out->u64(keyframe.id);
  out->u64(keyframe.map_id);
  out->u32(keyframe.session);
  out->u64(keyframe.stamp_ns);
  writePose(out, keyframe.odometry.position, keyframe.odometry.orientation);
  out->text(keyframe.odometry_frame);
}

bool readKeyframe(LittleEndianReader* in, GraphKeyframe* keyframe) {
  return in->u64(&keyframe->id) && in->u64(&keyframe->map_id) && in->u32(&keyframe->session) &&
         in->u64(&keyframe->stamp_ns) &&
         readPose(in, &keyframe->odometry.position, &keyframe->odometry.orientation) &&
         in->text(&keyframe->odometry_frame);
}

void writeLoop(LittleEndianWriter* out, const GraphLoop& loop) {
  out->u64(loop.map_id);
  out->u64(loop.match_map_id);
  out->u32(loop.query_session);
  out->u32(loop.match_session);
  out->u64(loop.query_stamp_ns);
  out->u64(loop.match_stamp_ns);
  out->text(loop.relative_pose_frame);
  out->u64(loop.constraint.query_id);
  out->u64(loop.constraint.match_id);
  const Eigen::Isometry3d& pose = loop.constraint.query_T_match;
  writePose(out, pose.translation(), Eigen::Quaterniond(pose.rotation()));
  for (int k = 0; k < 36; ++k) out->f64(loop.constraint.covariance(k));
}

bool readLoop(LittleEndianReader* in, GraphLoop* loop) {
  if (!in->u64(&loop->map_id) || !in->u64(&loop->match_map_id) || !in->u32(&loop->query_session) ||
      !in->u32(&loop->match_session) || !in->u64(&loop->query_stamp_ns) ||
      !in->u64(&loop->match_stamp_ns) || !in->text(&loop->relative_pose_frame) ||
      !in->u64(&loop->constraint.query_id) || !in->u64(&loop->constraint.match_id)) {
    return false;
  }
  Eigen::Vector3d position;
  Eigen::Quaterniond orientation;
  if (!readPose(in, &position, &orientation)) return false;
  // Not normalised: a quaternion damaged off unit length gives no rotation, which the graph
  // refuses as a bad pose.
  loop->constraint.query_T_match.setIdentity();
  loop->constraint.query_T_match.linear() = orientation.toRotationMatrix();
  loop->constraint.query_T_match.translation() = position;
  for (int k = 0; k < 36; ++k) {
    if (!in->f64(&loop->constraint.covariance(k))) return false;
  }
  // Only metric loops with a pose enter a graph: those are the ones saved.
  loop->has_relative_pose = loop->relative_pose_metric = true;
  return true;
}

}  // namespace

std::string saveGraphFile(const std::string& path,
                          const std::vector<PoseGraphSession::Input>& inputs) {
  LittleEndianWriter out;
  beginChecksummedFile(&out, kMagic, kVersion);
  out.u64(inputs.size());
  for (const PoseGraphSession::Input& input : inputs) {
    if (const auto* keyframe = std::get_if<GraphKeyframe>(&input)) {
      out.u32(kKeyframe);
      writeKeyframe(&out, *keyframe);
    } else {
      out.u32(kLoop);
      writeLoop(&out, std::get<GraphLoop>(input));
    }
  }
  return finishChecksummedFile(path, &out);
}

std::string readGraphFile(const std::string& path, std::vector<PoseGraphSession::Input>* inputs) {
  std::vector<uint8_t> body;
  const std::string problem = readChecksummedFile(path, kMagic, kVersion, "pose graph", &body);
  if (!problem.empty()) return problem;
  LittleEndianReader in(body.data(), body.size());
  uint64_t count = 0;
  if (!in.u64(&count) || count > kMaxInputs) return "its input count is damaged";
  inputs->clear();
  for (uint64_t k = 0; k < count; ++k) {
    uint32_t kind = 0;
    if (!in.u32(&kind)) return "it ends inside input " + std::to_string(k);
    if (kind == kKeyframe) {
      GraphKeyframe keyframe;
      if (!readKeyframe(&in, &keyframe))
        return "keyframe input " + std::to_string(k) + " is cut short";
      inputs->emplace_back(keyframe);
    } else if (kind == kLoop) {
      GraphLoop loop;
      if (!readLoop(&in, &loop)) return "loop input " + std::to_string(k) + " is cut short";
      inputs->emplace_back(loop);
    } else {
      return "input " + std::to_string(k) + " is of no known kind";
    }
  }
  if (in.remaining() != 0) return "bytes after its last input";
  return "";
}

}  // namespace landmark_loop_closure
