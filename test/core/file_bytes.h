#pragma once

// A whole file as bytes and back, for tests that damage or copy files.
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

namespace landmark_loop_closure {

inline std::vector<char> readBytes(const std::filesystem::path& path) {
  std::ifstream file(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>()};
}

inline void writeBytes(const std::filesystem::path& path, const std::vector<char>& bytes) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace landmark_loop_closure
