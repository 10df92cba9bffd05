#pragma once

#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "landmark_loop_closure/common/parameter_source.h"

namespace landmark_loop_closure {

/// The values a number option may take: finite and within [low, high], either end open.
struct ParameterRange {
  double low = -std::numeric_limits<double>::infinity();
  double high = std::numeric_limits<double>::infinity();
  bool low_open = false;
  bool high_open = false;

  bool contains(double value) const;
  /// ">= 0", "> 0", "in [1, 16]", "in (0, 1]"; "a finite number" when unbounded.
  std::string describe() const;
};
ParameterRange anyFinite();
ParameterRange atLeast(double low);
ParameterRange above(double low);
ParameterRange between(double low, double high);  ///< Closed: [low, high].
ParameterRange openBetween(double low, double high, bool low_open, bool high_open);

/// One line of the documented parameter file, flattened: a value, a map's own comment, or a
/// section heading. Keys are full paths ("advanced/keyframe/min_motion").
struct DocumentedParameter {
  enum class Kind { kValue, kMap, kSection };
  Kind kind = Kind::kValue;
  std::string key;
  std::string value;  ///< The default as YAML text (kValue only).
  std::string doc;
  /// Fixed in the node at its measured value; only the evaluation reads it (not rendered).
  bool evaluation_only = false;
};

/// Renders documented parameters as a YAML file: `preamble` (comment lines), then every key
/// nested under its maps with its default and its description wrapped beside it.
std::string renderParameterYaml(const std::vector<DocumentedParameter>& parameters,
                                const std::string& preamble);

/// YAML text of a default value: numbers that read back exactly, strings quoted where YAML would
/// read them as something else.
std::string yamlValueText(double value);
std::string yamlValueText(int value);
std::string yamlValueText(bool value);
std::string yamlValueText(const std::string& value);

/// Every parameter of one options struct declared once: key, member, allowed values and
/// description. The struct's in-class initialisers are the defaults. Reading, range checks and the
/// documented default file all walk this table. Keys are full paths: the table's prefix
/// ("keyframe/") joined with each entry's key; a nested struct's own table is linked with group().
template <typename Options>
class ParameterTable {
 public:
  ParameterTable(std::string prefix, std::string doc) : prefix_(std::move(prefix)) {
    if (!doc.empty() && !prefix_.empty() && prefix_.back() == '/') {
      documents_.push_back([key = prefix_.substr(0, prefix_.size() - 1), doc](
                               const Options&, std::vector<DocumentedParameter>* out) {
        out->push_back({DocumentedParameter::Kind::kMap, key, "", doc});
      });
    }
  }

  const std::string& prefix() const { return prefix_; }

  ParameterTable& number(const std::string& key, double Options::*member, ParameterRange range,
                         std::string doc) {
    return numeric(key, member, range, std::move(doc));
  }
  /// Every integer has both bounds (a queue of 2 000 000 000 keyframes is a typo, not a
  /// setting); the range is written into its documentation.
  ParameterTable& integer(const std::string& key, int Options::*member, ParameterRange range,
                          std::string doc) {
    if (!std::isfinite(range.low) || !std::isfinite(range.high)) {
      throw std::logic_error("integer parameter " + prefix_ + key + " is declared without bounds");
    }
    doc += std::string(doc.empty() ? "" : " ") + "Allowed: " + range.describe() + ".";
    return numeric(key, member, range, std::move(doc));
  }
  ParameterTable& flag(const std::string& key, bool Options::*member, std::string doc) {
    return plain(key, member, std::move(doc));
  }
  /// Free text: paths, layer names, number lists.
  ParameterTable& text(const std::string& key, std::string Options::*member, std::string doc) {
    return plain(key, member, std::move(doc));
  }
  /// Text that must be one of `words`; kept as text where it names something saved with a map.
  ParameterTable& word(const std::string& key, std::string Options::*member,
                       std::vector<std::string> words, std::string doc) {
    plain(key, member, std::move(doc));
    checks_.push_back(
        [full = prefix_ + key, member, words](const Options& options, std::string* errors) {
          const std::string& value = options.*member;
          for (const std::string& word : words) {
            if (word == value) return;
          }
          *errors += full + " must be one of " + quotedList(words) + " (got '" + value + "')\n";
        });
    return *this;
  }
  /// A word read straight into an enum; `names` pairs each word with its value.
  template <typename Enum>
  ParameterTable& choice(const std::string& key, Enum Options::*member,
                         const std::vector<std::pair<std::string, Enum>>& names, std::string doc) {
    const std::string full = prefix_ + key;
    readers_.push_back([full, member, names](OptionReader* reader, Options* options) {
      reader->readChoice(full, &(options->*member), names);
    });
    documents_.push_back([full, member, names, doc = std::move(doc)](
                             const Options& defaults, std::vector<DocumentedParameter>* out) {
      std::string word;
      for (const auto& [name, value] : names) {
        if (value == defaults.*member) word = name;
      }
      out->push_back({DocumentedParameter::Kind::kValue, full, yamlValueText(word), doc});
    });
    return *this;
  }
  /// A nested options struct with a table of its own. Its checks belong to its own validate(),
  /// so check() does not descend into it.
  template <typename Sub>
  ParameterTable& group(Sub Options::*member, const ParameterTable<Sub>& table) {
    const ParameterTable<Sub>* sub = &table;
    readers_.push_back([sub, member](OptionReader* reader, Options* options) {
      sub->read(reader, &(options->*member));
    });
    documents_.push_back(
        [sub, member](const Options& defaults, std::vector<DocumentedParameter>* out) {
          sub->document(defaults.*member, out);
        });
    return *this;
  }
  /// The comment of a map whose keys come later (`key` is its full path).
  ParameterTable& mapDoc(std::string key, std::string doc) {
    documents_.push_back([key = std::move(key), doc = std::move(doc)](
                             const Options&, std::vector<DocumentedParameter>* out) {
      out->push_back({DocumentedParameter::Kind::kMap, key, "", doc});
    });
    return *this;
  }
  /// Marks the entry declared last as the evaluation's alone: the node keeps its measured default
  /// (the in-class initialiser), the documented file leaves it out, and only a reader that
  /// readsEvaluationOnly() (lcd_evaluate --config) reads it. Its range is still checked.
  ParameterTable& evaluationOnly() {
    auto read_one = readers_.back();
    readers_.back() = [read_one](OptionReader* reader, Options* options) {
      if (reader->readsEvaluationOnly()) read_one(reader, options);
    };
    auto document_one = documents_.back();
    documents_.back() = [document_one](const Options& defaults,
                                       std::vector<DocumentedParameter>* out) {
      const size_t first = out->size();
      document_one(defaults, out);
      for (size_t i = first; i < out->size(); ++i) (*out)[i].evaluation_only = true;
    };
    return *this;
  }
  /// A heading comment before the next key in the documented file.
  ParameterTable& section(std::string title) {
    documents_.push_back(
        [title = std::move(title)](const Options&, std::vector<DocumentedParameter>* out) {
          out->push_back({DocumentedParameter::Kind::kSection, "", "", title});
        });
    return *this;
  }

  /// Reads every key into `options`; absent keys keep their values.
  void read(OptionReader* reader, Options* options) const {
    for (const auto& read_one : readers_) read_one(reader, options);
  }
  /// Range and word errors of this table's own entries, one line each; empty when all hold.
  std::string check(const Options& options) const {
    std::string errors;
    for (const auto& check_one : checks_) check_one(options, &errors);
    return errors;
  }
  /// Appends every entry, groups included, with its value in `defaults`.
  void document(const Options& defaults, std::vector<DocumentedParameter>* out) const {
    for (const auto& document_one : documents_) document_one(defaults, out);
  }

 private:
  static std::string quotedList(const std::vector<std::string>& words) {
    std::string list;
    for (const std::string& word : words) list += (list.empty() ? "'" : ", '") + word + "'";
    return list;
  }

  template <typename T>
  ParameterTable& plain(const std::string& key, T Options::*member, std::string doc) {
    const std::string full = prefix_ + key;
    readers_.push_back([full, member](OptionReader* reader, Options* options) {
      reader->read(full, &(options->*member));
    });
    documents_.push_back([full, member, doc = std::move(doc)](
                             const Options& defaults, std::vector<DocumentedParameter>* out) {
      out->push_back(
          {DocumentedParameter::Kind::kValue, full, yamlValueText(defaults.*member), doc});
    });
    return *this;
  }

  template <typename T>
  ParameterTable& numeric(const std::string& key, T Options::*member, ParameterRange range,
                          std::string doc) {
    plain(key, member, std::move(doc));
    checks_.push_back([full = prefix_ + key, member, range](const Options& options,
                                                            std::string* errors) {
      const T value = options.*member;
      if (!range.contains(static_cast<double>(value))) {
        *errors += full + " must be " + range.describe() + " (got " + yamlValueText(value) + ")\n";
      }
    });
    return *this;
  }

  std::string prefix_;
  std::vector<std::function<void(OptionReader*, Options*)>> readers_;
  std::vector<std::function<void(const Options&, std::string*)>> checks_;
  std::vector<std::function<void(const Options&, std::vector<DocumentedParameter>*)>> documents_;
};

}  // namespace landmark_loop_closure
