#include "ros_parameter_source.h"

#include <ros/console.h>

namespace landmark_loop_closure {

ParameterLookup fromXmlRpc(XmlRpc::XmlRpcValue& value, double* out) {
  if (value.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    *out = static_cast<double>(value);
  } else if (value.getType() == XmlRpc::XmlRpcValue::TypeInt) {
    *out = static_cast<int>(value);
  } else {
    return ParameterLookup::kWrongType;
  }
  return ParameterLookup::kFound;
}

ParameterLookup fromXmlRpc(XmlRpc::XmlRpcValue& value, int* out) {
  if (value.getType() != XmlRpc::XmlRpcValue::TypeInt) return ParameterLookup::kWrongType;
  *out = static_cast<int>(value);
  return ParameterLookup::kFound;
}

ParameterLookup fromXmlRpc(XmlRpc::XmlRpcValue& value, bool* out) {
  if (value.getType() != XmlRpc::XmlRpcValue::TypeBoolean) return ParameterLookup::kWrongType;
  *out = static_cast<bool>(value);
  return ParameterLookup::kFound;
}

ParameterLookup fromXmlRpc(XmlRpc::XmlRpcValue& value, std::string* out) {
  if (value.getType() != XmlRpc::XmlRpcValue::TypeString) return ParameterLookup::kWrongType;
  *out = static_cast<std::string>(value);
  return ParameterLookup::kFound;
}

ParameterLookup RosParameterSource::get(const std::string& key, double* value) const {
  return lookup(key, value);
}
ParameterLookup RosParameterSource::get(const std::string& key, int* value) const {
  return lookup(key, value);
}
ParameterLookup RosParameterSource::get(const std::string& key, bool* value) const {
  return lookup(key, value);
}
ParameterLookup RosParameterSource::get(const std::string& key, std::string* value) const {
  return lookup(key, value);
}

std::vector<std::string> RosParameterSource::keys() const {
  std::vector<std::string> all;
  std::vector<std::string> result;
  if (!node_.getParamNames(all)) return result;
  const std::string prefix = node_.getNamespace() + "/";
  for (const std::string& name : all) {
    if (name.compare(0, prefix.size(), prefix) == 0) result.push_back(name.substr(prefix.size()));
  }
  return result;
}

void warnUnknownParameters(const RosParameterSource& source, const OptionReader& reader,
                           const ros::NodeHandle& private_node, const std::string& documented_in) {
  for (const std::string& key : source.keys()) {
    if (!reader.isKnown(key)) {
      ROS_WARN("Unknown parameter %s/%s is ignored (misspelt? see %s)",
               private_node.getNamespace().c_str(), key.c_str(), documented_in.c_str());
    }
  }
}

}  // namespace landmark_loop_closure
