// Worker threads run work whose exceptions must not end the process (a nodelet manager shares it
// with the camera driver): run it, and say what escaped.
#pragma once

#include <exception>
#include <optional>
#include <string>

namespace landmark_loop_closure {

/// Runs `work`; nullopt when it returned, else what it threw (its what(), or a fixed text for an
/// exception that is not a std::exception).
template <typename Work>
std::optional<std::string> runCaught(Work&& work) {
  try {
    work();
    return std::nullopt;
  } catch (const std::exception& error) {
    return std::string(error.what());
  } catch (...) {
    return std::string("an exception that is not a std::exception");
  }
}

/// Runs a report of a failure, ignoring what it throws: reporting must not end the worker either.
template <typename Report>
void reportCaught(Report&& report) {
  runCaught(report);
}

}  // namespace landmark_loop_closure
