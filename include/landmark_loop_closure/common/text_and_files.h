// Small helpers for configuration text and files.
#pragma once

#include <string>
#include <vector>

namespace landmark_loop_closure {

/// FNV-1a hash (64 bit) of a file's bytes in hex ("missing" when it cannot be read).
std::string fileHash(const std::string& path);

/// "0.485, 0.456 0.406" -> {0.485, 0.456, 0.406}; throws std::invalid_argument on other text.
std::vector<double> parseNumberList(const std::string& text);

/// "/a, /b  /a" -> {"/a", "/b"}: words separated by spaces or commas, each once, in order.
std::vector<std::string> parseNameList(const std::string& text);

/// A path as a shell would read it: a leading "~" or "~/" becomes $HOME, "$NAME" and "${NAME}"
/// the variable's value. An unset variable is left as written, so the error that follows names it.
std::string expandPath(const std::string& path);

/// Two "key=value key=value" texts (a descriptor's identity) compared key by key: "key is A in
/// the first, B in the second" for each key that differs, joined by "; " (a key one side lacks
/// reads "(unset)"). "" when they agree key by key.
std::string keyValueDifferences(const std::string& first, const std::string& second,
                                const std::string& first_name, const std::string& second_name);

}  // namespace landmark_loop_closure
