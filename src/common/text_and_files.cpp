#include "landmark_loop_closure/common/text_and_files.h"

#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

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

}  // namespace landmark_loop_closure
