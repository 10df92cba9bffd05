#pragma once

// Damage as a failing disk leaves it, for the map tests (core and node).
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace landmark_loop_closure {
namespace test_support {

/// Turns over every bit of the 4 KiB page in the middle of `path` (at least 16 KiB long); false
/// when the file is shorter.
inline bool turnOverMiddlePage(const std::string& path) {
  const std::uintmax_t size = std::filesystem::file_size(path);
  if (size <= 16384u) return false;
  std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
  const auto middle = static_cast<std::streamoff>(size / 2 / 4096 * 4096);
  std::string page(4096, '\0');
  file.seekg(middle);
  file.read(&page[0], 4096);
  for (char& byte : page) byte = static_cast<char>(~byte);
  file.seekp(middle);
  file.write(page.data(), 4096);
  return static_cast<bool>(file);
}

}  // namespace test_support
}  // namespace landmark_loop_closure
