#include "landmark_loop_closure/descriptors/registry.h"

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
