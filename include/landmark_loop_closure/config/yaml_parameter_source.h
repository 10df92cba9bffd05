#pragma once

#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "landmark_loop_closure/common/parameter_source.h"

namespace landmark_loop_closure {

/// Parameters from a YAML file laid out as the nodelet's private namespace (nested maps).
class YamlParameterSource : public ParameterSource {
 public:
  /// Throws std::runtime_error naming the file when it cannot be read or parsed.
  static YamlParameterSource fromFile(const std::string& path);
  explicit YamlParameterSource(YAML::Node root) : root_(std::move(root)) {}

  ParameterLookup get(const std::string& key, double* value) const override;
  ParameterLookup get(const std::string& key, int* value) const override;
  ParameterLookup get(const std::string& key, bool* value) const override;
  ParameterLookup get(const std::string& key, std::string* value) const override;

  /// Every scalar's key, e.g. "advanced/keyframe/min_motion".
  std::vector<std::string> keys() const;

 private:
  template <typename T>
  ParameterLookup lookup(const std::string& key, T* value) const;
  YAML::Node find(const std::string& key) const;

  YAML::Node root_;
};

}  // namespace landmark_loop_closure
