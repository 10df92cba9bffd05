// Every descriptor type in one list. A type's own file defines its entry (name, validation,
// identity, factory, variant names); registry.cpp lists the entries, one line each. The node,
// lcd_evaluate and lcd_train all find types here, by the same names.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "landmark_loop_closure/descriptors/descriptor.h"

namespace landmark_loop_closure {

struct DescriptorType {
  std::string name;     ///< The value of advanced/descriptor/type.
  std::string summary;  ///< One line: what it is and how long its global vector is.
  /// Keys under descriptor/ this type reads besides type and condition_window; one ending in '/'
  /// is a whole group ("backbone/"). Any other key set away from its default is ignored by it.
  std::vector<std::string> reads;
  /// Problems with the options this type reads, one line each ending in '\n'; "" = usable.
  std::function<std::string(const DescriptorOptions&)> validate = [](const DescriptorOptions&) {
    return std::string();
  };
  /// What, besides the name, decides the values of its descriptors (model hashes, sizes,
  /// settings): descriptors of different identities cannot be compared.
  std::function<std::string(const DescriptorOptions&)> identity = [](const DescriptorOptions&) {
    return std::string();
  };
  /// The extractor; throws std::runtime_error when a model file cannot be loaded.
  std::function<std::shared_ptr<const DescriptorExtractor>(const DescriptorOptions&)> make;
  /// lcd_evaluate's variant names, "<name>_<part>_<part>": applies one part to the options;
  /// false when the part means nothing to this type.
  std::function<bool(const std::string& part, DescriptorOptions*)> apply_variant_part =
      [](const std::string&, DescriptorOptions*) { return false; };
};

/// Every type, in the order help texts list them.
const std::vector<DescriptorType>& descriptorRegistry();

/// The type called `name`; nullptr when there is none.
const DescriptorType* findDescriptorType(const std::string& name);

/// Keys ("advanced/descriptor/model") set away from their defaults that `options.type` does not
/// read: a user who set them expects an effect they do not have. Empty for an unknown type.
std::vector<std::string> ignoredDescriptorParameters(const DescriptorOptions& options);

/// The registered type whose name starts `variant` ("hog_whole_x" -> hog_whole, not hog);
/// nullptr when none does.
const DescriptorType* descriptorTypeOfVariant(const std::string& variant);

/// The options of a variant name ("backbone_g3x4_m30", "landmarks_per_landmark"): `base` with
/// the type set and each '_'-separated part applied by the type. Throws std::invalid_argument
/// naming the part when the type does not know it.
DescriptorOptions applyDescriptorVariant(const std::string& variant, DescriptorOptions base);

// The entries, each defined in its type's file.
DescriptorType backboneDescriptorType();
DescriptorType landmarksDescriptorType();
DescriptorType calcDescriptorType();
DescriptorType hogDescriptorType();
DescriptorType hogWholeDescriptorType();
DescriptorType pixelsDescriptorType();
DescriptorType cnnPcaDescriptorType();
DescriptorType broadDescriptorType();

}  // namespace landmark_loop_closure
