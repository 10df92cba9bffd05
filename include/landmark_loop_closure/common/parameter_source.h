#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace landmark_loop_closure {

enum class ParameterLookup { kAbsent, kFound, kWrongType };

/// Where option values come from: the ROS parameter server in the node, a YAML file offline and
/// in tests. Keys are relative paths such as "advanced/keyframe/min_motion".
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
  /// The key's earlier name when the value was found only under it (OptionReader::setOldNames).
  std::string found_under_old_name;
};

/// Reads options from a source, keeping the in-class default where a key is absent, and records
/// every key asked for, so callers can report unknown keys and tests can compare documentation
/// with code.
class OptionReader {
 public:
  explicit OptionReader(const ParameterSource& source) : source_(source) {}

  /// Keys that were renamed: `old_name(key)` gives a key's earlier name ("" when it had none). A
  /// value under that name is read first, and the record says so, so a file written for the
  /// earlier layout keeps working while its reader names what moved.
  void setOldNames(std::function<std::string(const std::string&)> old_name) {
    old_name_ = std::move(old_name);
  }
  /// Whether keys the node keeps fixed (ParameterTable::evaluationOnly) are read too: by the
  /// evaluation, which varies them; the node never does.
  void setReadsEvaluationOnly(bool reads) { reads_evaluation_only_ = reads; }
  bool readsEvaluationOnly() const { return reads_evaluation_only_; }

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
    const ParameterLookup lookup = lookUp(key, &text, &record);
    if (lookup == ParameterLookup::kWrongType) {
      errors_ += sourceKey(record) + " must be a string\n";
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
      if (!known) {
        errors_ += sourceKey(record) + " must be one of " + names + " (got '" + text + "')\n";
      }
    }
    records_.push_back(record);
  }

  const std::vector<ParameterRecord>& records() const { return records_; }
  /// Type errors, one per line ("advanced/keyframe/min_motion must be a number").
  const std::string& errors() const { return errors_; }
  /// Whether `key` is one of the keys read so far, or the earlier name one was found under.
  bool isKnown(const std::string& key) const;

 private:
  // The key as the source has it: its old name when the value was found only under that.
  static const std::string& sourceKey(const ParameterRecord& record) {
    return record.found_under_old_name.empty() ? record.key : record.found_under_old_name;
  }

  // The old name wins where both are set: the shipped file holds only the new names, so a value
  // under the old one is the user's own, from a file written for the earlier layout.
  template <typename T>
  ParameterLookup lookUp(const std::string& key, T* value, ParameterRecord* record) const {
    const std::string old_key = old_name_ ? old_name_(key) : std::string();
    if (!old_key.empty()) {
      const ParameterLookup old_lookup = source_.get(old_key, value);
      if (old_lookup != ParameterLookup::kAbsent) {
        record->found_under_old_name = old_key;
        return old_lookup;
      }
    }
    return source_.get(key, value);
  }

  template <typename T>
  void readAny(const std::string& key, T* value, const char* expected) {
    ParameterRecord record;
    record.key = key;
    T loaded = *value;
    const ParameterLookup lookup = lookUp(key, &loaded, &record);
    if (lookup == ParameterLookup::kWrongType) {
      errors_ += sourceKey(record) + " must be " + expected + "\n";
    } else if (lookup == ParameterLookup::kFound) {
      record.found = true;
      record.equals_default = loaded == *value;
      *value = loaded;
    }
    records_.push_back(record);
  }

  const ParameterSource& source_;
  std::function<std::string(const std::string&)> old_name_;
  bool reads_evaluation_only_ = false;
  std::vector<ParameterRecord> records_;
  std::string errors_;
};

}  // namespace landmark_loop_closure
