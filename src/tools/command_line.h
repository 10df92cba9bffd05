// The tools' command lines, parsed by CLI11: --help is generated from the options, and every tool
// reports a bad command line the same way (the problem, then a pointer to --help) with exit 2.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace landmark_loop_closure {
namespace tools {

/// Parses argv into `app`. Returns the code main returns at once (0 after --help, 2 after a bad
/// command line, reported on stderr), or nothing when the tool goes on.
inline std::optional<int> parseCommandLine(CLI::App* app, int argc, char** argv) {
  try {
    app->parse(argc, argv);
    return std::nullopt;
  } catch (const CLI::CallForHelp& help) {
    return app->exit(help);
  } catch (const CLI::CallForAllHelp& help) {
    return app->exit(help);
  } catch (const CLI::ParseError& error) {
    app->exit(error);
    return 2;
  }
}

/// An option of a tool that keeps its options as text (lcd_evaluate, lcd_train): `flag` takes no
/// value.
struct TextOption {
  const char* name;
  const char* help;
  bool flag = false;
};

/// Declares `options` on `app`; parsing puts each one given into `values` (a flag as "true").
inline void addTextOptions(CLI::App* app, const std::vector<TextOption>& options,
                           std::map<std::string, std::string>* values) {
  for (const TextOption& option : options) {
    const std::string name = option.name;
    if (option.flag) {
      app->add_flag_callback(
          name, [values, name] { (*values)[name] = "true"; }, option.help);
    } else {
      app->add_option_function<std::string>(
          name, [values, name](const std::string& value) { (*values)[name] = value; }, option.help);
    }
  }
}

}  // namespace tools
}  // namespace landmark_loop_closure
