// Uses the public headers that bring OpenCV, Eigen and yaml-cpp, and links the core and config
// libraries: exits 0 when a keyframe stored in a database is found again and a YAML parameter
// text is read.
#include <cstdio>

#include "landmark_loop_closure/config/yaml_parameter_source.h"
#include "landmark_loop_closure/database/keyframe_database.h"
#include "landmark_loop_closure/geometry/pose.h"

int main() {
  using namespace landmark_loop_closure;
  KeyframeDatabase database(4);
  KeyframeRecord keyframe;
  keyframe.id = 7;
  keyframe.descriptor.global = {0.5f, 0.5f, 0.5f, 0.5f};
  keyframe.pose.position = Eigen::Vector3d(1.0, 2.0, 3.0);
  database.add(keyframe);
  DatabaseOptions options;
  options.min_size = 1;
  options.exclude_recent_keyframes = 0;
  options.exclude_recent_seconds = 0.0;
  const QueryResult found = database.query({0.5f, 0.5f, 0.5f, 0.5f}, 100.0, options);
  const YamlParameterSource parameters(YAML::Load("advanced: {keyframe: {min_motion: 0.5}}"));
  double min_motion = 0.0;
  parameters.get("advanced/keyframe/min_motion", &min_motion);
  const bool ok = found.candidates.size() == 1 && found.candidates.front().id == 7 &&
                  min_motion == 0.5;
  std::printf("downstream: %s\n", ok ? "found the stored keyframe" : "did not find the keyframe");
  return ok ? 0 : 1;
}
