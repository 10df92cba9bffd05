// Where the package's own files are: its models (model/calc_encoder.onnx, model/mobilenet_v2.onnx)
// and its documented defaults (config/default.yaml), in the source tree or an install space.
#pragma once

#include <string>

namespace landmark_loop_closure {

/// The first that exists of: $LANDMARK_LOOP_CLOSURE_MODEL_DIR; the directory given to
/// setModelDirectory() (the node gives the ROS package path's model/); for an installed library,
/// <prefix>/share/landmark_loop_closure/model beside the <prefix>/lib it was loaded from; the
/// source tree's model/ this library was built from.
std::string modelDirectory();

/// The package's documented defaults, config/default.yaml: for an installed library the copy in
/// <prefix>/share/landmark_loop_closure/config, else the source tree's it was built from.
std::string defaultConfigFile();

/// Makes `directory` the package's model directory when it exists; false (and no change) when it
/// does not.
bool setModelDirectory(const std::string& directory);

}  // namespace landmark_loop_closure
