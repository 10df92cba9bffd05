#pragma once

#include <string>
#include <vector>

#include <ros/node_handle.h>

#include "landmark_loop_closure/common/parameter_source.h"

namespace landmark_loop_closure {

/// A parameter server value as the type asked for, strictly: an integer key refuses 2.5 instead
/// of truncating it; a number key takes an integer.
ParameterLookup fromXmlRpc(XmlRpc::XmlRpcValue& value, double* out);
ParameterLookup fromXmlRpc(XmlRpc::XmlRpcValue& value, int* out);
ParameterLookup fromXmlRpc(XmlRpc::XmlRpcValue& value, bool* out);
ParameterLookup fromXmlRpc(XmlRpc::XmlRpcValue& value, std::string* out);

/// Parameters from the ROS parameter server, relative to a (private) node handle.
class RosParameterSource : public ParameterSource {
 public:
  explicit RosParameterSource(const ros::NodeHandle& node) : node_(node) {}

  ParameterLookup get(const std::string& key, double* value) const override;
  ParameterLookup get(const std::string& key, int* value) const override;
  ParameterLookup get(const std::string& key, bool* value) const override;
  ParameterLookup get(const std::string& key, std::string* value) const override;

  /// Keys set under the node handle's namespace, relative to it ("advanced/keyframe/min_motion").
  std::vector<std::string> keys() const;

 private:
  template <typename T>
  ParameterLookup lookup(const std::string& key, T* value) const {
    XmlRpc::XmlRpcValue raw;
    if (!node_.hasParam(key) || !node_.getParam(key, raw)) return ParameterLookup::kAbsent;
    return fromXmlRpc(raw, value);
  }

  ros::NodeHandle node_;
};

/// One WARN per key set under the node's namespace that `reader` did not read (misspelt?),
/// pointing at `documented_in`, the file that lists every key.
void warnUnknownParameters(const RosParameterSource& source, const OptionReader& reader,
                           const ros::NodeHandle& private_node, const std::string& documented_in);

}  // namespace landmark_loop_closure
