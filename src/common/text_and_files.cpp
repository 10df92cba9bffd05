#include "landmark_loop_closure/common/text_and_files.h"

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

}  // namespace landmark_loop_closure
