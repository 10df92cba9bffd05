#pragma once

#include <string>
#include <vector>

#include <ros/node_handle.h>

#include "landmark_loop_closure/common/parameter_source.h"

namespace landmark_loop_closure {

/// Parameters from the ROS parameter server, relative to a (private) node handle.
class RosParameterSource : public ParameterSource {
 public:
  explicit RosParameterSource(const ros::NodeHandle& node) : node_(node) {}

  ParameterLookup get(const std::string& key, double* value) const override;
  ParameterLookup get(const std::string& key, int* value) const override;
  ParameterLookup get(const std::string& key, bool* value) const override;
  ParameterLookup get(const std::string& key, std::string* value) const override;

  /// Keys set under the node handle's namespace, relative to it ("keyframe/min_motion").
  std::vector<std::string> keys() const;

 private:
  template <typename T>
  ParameterLookup lookup(const std::string& key, T* value) const {
    if (!node_.hasParam(key)) return ParameterLookup::kAbsent;
    return node_.getParam(key, *value) ? ParameterLookup::kFound : ParameterLookup::kWrongType;
  }

  ros::NodeHandle node_;
};

}  // namespace landmark_loop_closure
