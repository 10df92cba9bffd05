#pragma once

// The inputs scripts/fuzz.sh starts from, and the ones it kept because they once failed:
// every gtest that replays a fuzz target reads them the same way.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace landmark_loop_closure {

struct KeptFuzzInput {
  std::filesystem::path path;
  std::vector<uint8_t> bytes;
};

// All files of fuzz/seeds/<target>/, in name order so a failure names the same file every run.
inline std::vector<KeptFuzzInput> keptFuzzInputs(const std::string& target) {
  namespace fs = std::filesystem;
  const fs::path folder = fs::path(PACKAGE_SOURCE_DIR) / "fuzz" / "seeds" / target;
  std::vector<KeptFuzzInput> inputs;
  if (!fs::is_directory(folder)) return inputs;
  for (const auto& entry : fs::directory_iterator(folder)) {
    std::ifstream file(entry.path(), std::ios::binary);
    inputs.push_back(
        {entry.path(), {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()}});
  }
  std::sort(inputs.begin(), inputs.end(),
            [](const KeptFuzzInput& a, const KeptFuzzInput& b) { return a.path < b.path; });
  return inputs;
}

}  // namespace landmark_loop_closure
