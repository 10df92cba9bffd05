#include "landmark_loop_closure/common/text_and_files.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace landmark_loop_closure {

std::string fileHash(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) return "missing";
  uint64_t hash = 1469598103934665603ull;  // FNV-1a, 64 bit.
  char buffer[1 << 16];
  while (file.read(buffer, sizeof(buffer)) || file.gcount() > 0) {
    for (std::streamsize i = 0; i < file.gcount(); ++i) {
      hash = (hash ^ static_cast<unsigned char>(buffer[i])) * 1099511628211ull;
    }
  }
  char text[17];
  std::snprintf(text, sizeof(text), "%llx", static_cast<unsigned long long>(hash));
  return text;
}

std::vector<std::string> parseNameList(const std::string& text) {
  std::string spaced = text;
  for (char& c : spaced) {
    if (c == ',') c = ' ';
  }
  std::istringstream stream(spaced);
  std::vector<std::string> names;
  for (std::string word; stream >> word;) {
    if (std::find(names.begin(), names.end(), word) == names.end()) names.push_back(word);
  }
  return names;
}

std::vector<double> parseNumberList(const std::string& text) {
  std::string spaced = text;
  for (char& c : spaced) {
    if (c == ',') c = ' ';
  }
  std::istringstream stream(spaced);
  std::vector<double> values;
  std::string word;
  while (stream >> word) {
    char* end = nullptr;
    const double value = std::strtod(word.c_str(), &end);
    if (end == word.c_str() || *end != '\0' || !std::isfinite(value)) {
      throw std::invalid_argument("'" + text + "' is not a list of numbers");
    }
    values.push_back(value);
  }
  return values;
}

std::string expandPath(const std::string& path) {
  std::string expanded;
  size_t start = 0;
  const char* home = std::getenv("HOME");
  if (home != nullptr && !path.empty() && path[0] == '~' && (path.size() == 1 || path[1] == '/')) {
    expanded = home;
    start = 1;
  }
  for (size_t i = start; i < path.size(); ++i) {
    if (path[i] != '$' || i + 1 >= path.size()) {
      expanded += path[i];
      continue;
    }
    const bool braced = path[i + 1] == '{';
    size_t end = i + (braced ? 2 : 1);
    while (end < path.size() &&
           (std::isalnum(static_cast<unsigned char>(path[end])) || path[end] == '_')) {
      ++end;
    }
    const size_t name_start = i + (braced ? 2 : 1);
    const std::string name = path.substr(name_start, end - name_start);
    const bool closed = !braced || (end < path.size() && path[end] == '}');
    const char* value = name.empty() || !closed ? nullptr : std::getenv(name.c_str());
    if (value == nullptr) {
      expanded += path[i];  // Not a variable, or unset: kept as written.
      continue;
    }
    expanded += value;
    i = end + (braced ? 1 : 0) - 1;
  }
  return expanded;
}

std::string keyValueDifferences(const std::string& first, const std::string& second,
                                const std::string& first_name, const std::string& second_name) {
  // Keys in first-seen order, so the message follows the identity's own order.
  std::vector<std::string> keys;
  std::map<std::string, std::pair<std::string, std::string>> values;
  const auto read = [&](const std::string& text, bool is_first) {
    std::istringstream words(text);
    std::string word;
    while (words >> word) {
      const size_t equals = word.find('=');
      const std::string key = equals == std::string::npos ? word : word.substr(0, equals);
      const std::string value = equals == std::string::npos ? "" : word.substr(equals + 1);
      if (values.find(key) == values.end()) {
        keys.push_back(key);
        values[key] = {"(unset)", "(unset)"};
      }
      (is_first ? values[key].first : values[key].second) = value;
    }
  };
  read(first, true);
  read(second, false);
  std::string differences;
  for (const std::string& key : keys) {
    const auto& [a, b] = values[key];
    if (a == b) continue;
    if (!differences.empty()) differences += "; ";
    differences += key + " is " + a + " in " + first_name + ", " + b + " in " + second_name;
  }
  return differences;
}

}  // namespace landmark_loop_closure
