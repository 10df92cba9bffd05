#include "landmark_loop_closure/common/model_directory.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>

namespace landmark_loop_closure {

namespace {

std::mutex& directoryMutex() {
  static std::mutex mutex;
  return mutex;
}

std::string& chosenDirectory() {
  static std::string directory;
  return directory;
}

// <prefix>/share/landmark_loop_closure/model when this library lies in <prefix>/lib (installed).
std::string installedDirectory() {
  Dl_info info;
  if (dladdr(reinterpret_cast<void*>(&modelDirectory), &info) == 0 || info.dli_fname == nullptr) {
    return "";
  }
  std::error_code error;
  const std::filesystem::path library = std::filesystem::canonical(info.dli_fname, error);
  if (error) return "";
  const std::filesystem::path model =
      library.parent_path().parent_path() / "share" / "landmark_loop_closure" / "model";
  return std::filesystem::is_directory(model, error) ? model.string() : "";
}

}  // namespace

std::string modelDirectory() {
  std::error_code error;
  const char* environment = std::getenv("LANDMARK_LOOP_CLOSURE_MODEL_DIR");
  if (environment != nullptr && std::filesystem::is_directory(environment, error)) {
    return environment;
  }
  {
    const std::lock_guard<std::mutex> lock(directoryMutex());
    if (!chosenDirectory().empty()) return chosenDirectory();
  }
  static const std::string installed = installedDirectory();
  return installed.empty() ? LANDMARK_LOOP_CLOSURE_MODEL_DIR : installed;
}

bool setModelDirectory(const std::string& directory) {
  std::error_code error;
  if (directory.empty() || !std::filesystem::is_directory(directory, error)) return false;
  const std::lock_guard<std::mutex> lock(directoryMutex());
  chosenDirectory() = directory;
  return true;
}

}  // namespace landmark_loop_closure
