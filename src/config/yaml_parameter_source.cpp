#include "landmark_loop_closure/config/yaml_parameter_source.h"

#include <sstream>
#include <stdexcept>

namespace landmark_loop_closure {

namespace {

void collectKeys(const YAML::Node& node, const std::string& prefix, std::vector<std::string>* out) {
  if (!node.IsMap()) {
    out->push_back(prefix);
    return;
  }
  for (const auto& entry : node) {
    const std::string name = entry.first.as<std::string>();
    collectKeys(entry.second, prefix.empty() ? name : prefix + "/" + name, out);
  }
}

}  // namespace

YamlParameterSource YamlParameterSource::fromFile(const std::string& path) {
  try {
    return YamlParameterSource(YAML::LoadFile(path));
  } catch (const YAML::Exception& error) {
    throw std::runtime_error("cannot read parameters from " + path + ": " + error.what());
  }
}

YAML::Node YamlParameterSource::find(const std::string& key) const {
  // Assigning one yaml-cpp Node to another overwrites the referenced node instead of rebinding,
  // so each level of the walk gets a Node of its own.
  std::vector<YAML::Node> path{root_};
  std::istringstream parts(key);
  std::string part;
  while (std::getline(parts, part, '/')) {
    const YAML::Node& current = path.back();
    if (!current.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
    path.push_back(current[part]);
    if (!path.back().IsDefined()) return YAML::Node(YAML::NodeType::Undefined);
  }
  return path.back();
}

template <typename T>
ParameterLookup YamlParameterSource::lookup(const std::string& key, T* value) const {
  const YAML::Node node = find(key);
  if (!node.IsDefined() || node.IsNull()) return ParameterLookup::kAbsent;
  if (!node.IsScalar()) return ParameterLookup::kWrongType;
  try {
    *value = node.as<T>();
  } catch (const YAML::Exception&) {
    return ParameterLookup::kWrongType;
  }
  return ParameterLookup::kFound;
}

ParameterLookup YamlParameterSource::get(const std::string& key, double* value) const {
  return lookup(key, value);
}
ParameterLookup YamlParameterSource::get(const std::string& key, int* value) const {
  return lookup(key, value);
}
ParameterLookup YamlParameterSource::get(const std::string& key, bool* value) const {
  return lookup(key, value);
}
ParameterLookup YamlParameterSource::get(const std::string& key, std::string* value) const {
  return lookup(key, value);
}

std::vector<std::string> YamlParameterSource::keys() const {
  std::vector<std::string> result;
  if (root_.IsMap()) collectKeys(root_, "", &result);
  return result;
}

}  // namespace landmark_loop_closure
