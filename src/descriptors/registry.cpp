#include "landmark_loop_closure/descriptors/registry.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace landmark_loop_closure {

const std::vector<DescriptorType>& descriptorRegistry() {
  static const std::vector<DescriptorType> types = {
      backboneDescriptorType(), landmarksDescriptorType(), calcDescriptorType(),
      hogDescriptorType(),      hogWholeDescriptorType(),  pixelsDescriptorType(),
      cnnPcaDescriptorType(),   broadDescriptorType(),
  };
  return types;
}

const DescriptorType* findDescriptorType(const std::string& name) {
  for (const DescriptorType& type : descriptorRegistry()) {
    if (type.name == name) return &type;
  }
  return nullptr;
}

std::vector<std::string> ignoredDescriptorParameters(const DescriptorOptions& options) {
  const DescriptorType* type = findDescriptorType(options.type);
  if (type == nullptr) return {};
  std::vector<DocumentedParameter> set;
  std::vector<DocumentedParameter> defaults;
  DescriptorOptions::parameters().document(options, &set);
  DescriptorOptions::parameters().document(DescriptorOptions(), &defaults);
  const std::string prefix = DescriptorOptions::parameters().prefix();
  std::vector<std::string> read = type->reads;
  read.insert(read.end(), {"type", "condition_window"});
  std::vector<std::string> ignored;
  for (size_t i = 0; i < set.size() && i < defaults.size(); ++i) {
    const DocumentedParameter& entry = set[i];
    if (entry.kind != DocumentedParameter::Kind::kValue || entry.value == defaults[i].value) {
      continue;
    }
    const std::string key = entry.key.substr(entry.key.rfind(prefix, 0) == 0 ? prefix.size() : 0);
    const bool is_read = std::any_of(read.begin(), read.end(), [&key](const std::string& name) {
      return name.back() == '/' ? key.rfind(name, 0) == 0 : key == name;
    });
    if (!is_read) ignored.push_back(entry.key);
  }
  return ignored;
}

const DescriptorType* descriptorTypeOfVariant(const std::string& variant) {
  const DescriptorType* longest = nullptr;
  for (const DescriptorType& type : descriptorRegistry()) {
    const bool starts = variant.rfind(type.name, 0) == 0 &&
                        (variant.size() == type.name.size() || variant[type.name.size()] == '_');
    if (starts && (longest == nullptr || type.name.size() > longest->name.size())) longest = &type;
  }
  return longest;
}

DescriptorOptions applyDescriptorVariant(const std::string& variant, DescriptorOptions base) {
  const DescriptorType* type = descriptorTypeOfVariant(variant);
  if (type == nullptr) throw std::invalid_argument("unknown descriptor '" + variant + "'");
  base.type = type->name;
  std::istringstream parts(variant.substr(type->name.size()));
  std::string part;
  while (std::getline(parts, part, '_')) {
    if (part.empty()) continue;
    if (!type->apply_variant_part(part, &base)) {
      throw std::invalid_argument("unknown descriptor variant '" + variant + "': " + type->name +
                                  " has no '" + part + "'");
    }
  }
  return base;
}

}  // namespace landmark_loop_closure
