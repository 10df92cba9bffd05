#pragma once

#include <string>
#include <utility>
#include <vector>

namespace landmark_loop_closure {

enum class ParameterLookup { kAbsent, kFound, kWrongType };

/// Where option values come from: the ROS parameter server in the node, a YAML file offline and
/// in tests. Keys are relative paths such as "keyframe/min_motion".
class ParameterSource {
 public:
  virtual ~ParameterSource() = default;
  virtual ParameterLookup get(const std::string& key, double* value) const = 0;
  virtual ParameterLookup get(const std::string& key, int* value) const = 0;
  virtual ParameterLookup get(const std::string& key, bool* value) const = 0;
  virtual ParameterLookup get(const std::string& key, std::string* value) const = 0;
};

/// One option as read: whether the source had it and whether that equals the built-in default.
struct ParameterRecord {
  std::string key;
  bool found = false;
  bool equals_default = true;
};

/// Reads options from a source, keeping the in-class default where a key is absent, and records
/// every key asked for, so callers can report unknown keys and tests can compare documentation
/// with code.
class OptionReader {
 public:
  explicit OptionReader(const ParameterSource& source) : source_(source) {}

  void read(const std::string& key, double* value) { readAny(key, value, "a number"); }
  void read(const std::string& key, int* value) { readAny(key, value, "an integer"); }
  void read(const std::string& key, bool* value) { readAny(key, value, "true or false"); }
  void read(const std::string& key, std::string* value) { readAny(key, value, "a string"); }

  /// A string naming one of `choices`, stored as its value; any other text is an error that names
  /// them all, and the default is kept.
  template <typename Enum>
  void readChoice(const std::string& key, Enum* value,
                  const std::vector<std::pair<std::string, Enum>>& choices) {
    std::string default_text;
    for (const auto& [name, choice] : choices) {
      if (choice == *value) default_text = name;
    }
    ParameterRecord record;
    record.key = key;
    std::string text = default_text;
    const ParameterLookup lookup = source_.get(key, &text);
    if (lookup == ParameterLookup::kWrongType) {
      errors_ += key + " must be a string\n";
    } else if (lookup == ParameterLookup::kFound) {
      record.found = true;
      record.equals_default = text == default_text;
      bool known = false;
      std::string names;
      for (const auto& [name, choice] : choices) {
        names += (names.empty() ? "'" : ", '") + name + "'";
        if (name == text) {
          *value = choice;
          known = true;
        }
      }
      if (!known) errors_ += key + " must be one of " + names + " (got '" + text + "')\n";
    }
    records_.push_back(record);
  }

  const std::vector<ParameterRecord>& records() const { return records_; }
  /// Type errors, one per line ("keyframe/min_motion must be a number").
  const std::string& errors() const { return errors_; }
  /// Whether `key` is one of the keys read so far.
  bool isKnown(const std::string& key) const;

 private:
  template <typename T>
  void readAny(const std::string& key, T* value, const char* expected) {
    ParameterRecord record;
    record.key = key;
    T loaded = *value;
    const ParameterLookup lookup = source_.get(key, &loaded);
    if (lookup == ParameterLookup::kWrongType) {
      errors_ += key + " must be " + expected + "\n";
    } else if (lookup == ParameterLookup::kFound) {
      record.found = true;
      record.equals_default = loaded == *value;
      *value = loaded;
    }
    records_.push_back(record);
  }

  const ParameterSource& source_;
  std::vector<ParameterRecord> records_;
  std::string errors_;
};

}  // namespace landmark_loop_closure
