#pragma once

// A test fixture with a folder of its own under the system's temporary directory, named by the
// process and the test, removed after the test.
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

namespace landmark_loop_closure {
namespace test {

class TemporaryFolderTest : public ::testing::Test {
 protected:
  explicit TemporaryFolderTest(std::string prefix) : prefix_(std::move(prefix)) {}
  void SetUp() override {
    directory_ = std::filesystem::temp_directory_path() /
                 (prefix_ + std::to_string(::getpid()) + "_" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(directory_);
  }
  void TearDown() override { std::filesystem::remove_all(directory_); }
  std::string path(const std::string& name) const { return (directory_ / name).string(); }

  std::filesystem::path directory_;

 private:
  std::string prefix_;
};

}  // namespace test
}  // namespace landmark_loop_closure
