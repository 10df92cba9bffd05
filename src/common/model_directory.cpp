#include "landmark_loop_closure/common/model_directory.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>

#include "landmark_loop_closure/common/thread_annotations.h"

namespace landmark_loop_closure {

namespace {

// setModelDirectory()'s choice.
struct ChosenDirectory {
  Mutex mutex;
  std::string path GUARDED_BY(mutex);
};

ChosenDirectory& chosenDirectory() {
  static ChosenDirectory chosen;
  return chosen;
}

// <prefix>/share/landmark_loop_closure/<folder> when this library lies in <prefix>/lib
// (installed) and it exists there.
std::string installedDirectory(const char* folder) {
  Dl_info info;
  if (dladdr(reinterpret_cast<void*>(&modelDirectory), &info) == 0 || info.dli_fname == nullptr) {
    return "";
  }
  std::error_code error;
  const std::filesystem::path library = std::filesystem::canonical(info.dli_fname, error);
  if (error) return "";
  const std::filesystem::path directory =
      library.parent_path().parent_path() / "share" / "landmark_loop_closure" / folder;
  return std::filesystem::is_directory(directory, error) ? directory.string() : "";
}

}  // namespace

std::string modelDirectory() {
  std::error_code error;
  const char* environment = std::getenv("LANDMARK_LOOP_CLOSURE_MODEL_DIR");
  if (environment != nullptr && std::filesystem::is_directory(environment, error)) {
    return environment;
  }
  {
    ChosenDirectory& chosen = chosenDirectory();
    MutexLock lock(chosen.mutex);
    if (!chosen.path.empty()) return chosen.path;
  }
  static const std::string installed = installedDirectory("model");
  return installed.empty() ? LANDMARK_LOOP_CLOSURE_MODEL_DIR : installed;
}

std::string defaultConfigFile() {
  static const std::string installed = installedDirectory("config");
  return installed.empty() ? LANDMARK_LOOP_CLOSURE_CONFIG_DIR "/default.yaml"
                           : installed + "/default.yaml";
}

bool setModelDirectory(const std::string& directory) {
  std::error_code error;
  if (directory.empty() || !std::filesystem::is_directory(directory, error)) return false;
  ChosenDirectory& chosen = chosenDirectory();
  MutexLock lock(chosen.mutex);
  chosen.path = directory;
  return true;
}

}  // namespace landmark_loop_closure
