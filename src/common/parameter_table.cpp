#include "landmark_loop_closure/common/parameter_table.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <sstream>

namespace landmark_loop_closure {

bool OptionReader::isKnown(const std::string& key) const {
  return std::any_of(records_.begin(), records_.end(), [&key](const ParameterRecord& record) {
    return record.key == key || record.found_under_old_name == key;
  });
}

bool ParameterRange::contains(double value) const {
  if (!std::isfinite(value)) return false;
  const bool above_low = low_open ? value > low : value >= low;
  const bool below_high = high_open ? value < high : value <= high;
  return above_low && below_high;
}

namespace {

/// A bound as people write it: "16", "0.5".
std::string boundText(double value) {
  if (value == std::floor(value) && std::abs(value) < 1e15) {
    return std::to_string(static_cast<long long>(value));
  }
  return yamlValueText(value);
}

}  // namespace

std::string ParameterRange::describe() const {
  const bool bounded_low = std::isfinite(low);
  const bool bounded_high = std::isfinite(high);
  if (bounded_low && bounded_high) {
    return "in " + std::string(low_open ? "(" : "[") + boundText(low) + ", " + boundText(high) +
           (high_open ? ")" : "]");
  }
  if (bounded_low) return (low_open ? "> " : ">= ") + boundText(low);
  if (bounded_high) return (high_open ? "< " : "<= ") + boundText(high);
  return "a finite number";
}

ParameterRange anyFinite() { return ParameterRange{}; }

ParameterRange atLeast(double low) {
  ParameterRange range;
  range.low = low;
  return range;
}

ParameterRange above(double low) {
  ParameterRange range = atLeast(low);
  range.low_open = true;
  return range;
}

ParameterRange between(double low, double high) { return openBetween(low, high, false, false); }

ParameterRange openBetween(double low, double high, bool low_open, bool high_open) {
  ParameterRange range;
  range.low = low;
  range.high = high;
  range.low_open = low_open;
  range.high_open = high_open;
  return range;
}

std::string yamlValueText(double value) {
  if (std::isnan(value)) return ".nan";
  if (std::isinf(value)) return value > 0 ? ".inf" : "-.inf";
  char text[32];
  if (value == std::floor(value) && std::abs(value) < 1e15) {
    std::snprintf(text, sizeof(text), "%.1f", value);
    return text;
  }
  // The shortest text that reads back as the same double.
  for (int precision = 1; precision <= 17; ++precision) {
    std::snprintf(text, sizeof(text), "%.*g", precision, value);
    if (std::strtod(text, nullptr) == value) break;
  }
  return text;
}

std::string yamlValueText(int value) { return std::to_string(value); }

std::string yamlValueText(bool value) { return value ? "true" : "false"; }

std::string yamlValueText(const std::string& value) {
  static const char* const kReserved[] = {"true", "false", "yes", "no",   "on",
                                          "off",  "null",  "~",   "True", "False"};
  bool quote = value.empty() || value.find_first_of(" #:'\"{}[],&*!|>%@`") != std::string::npos;
  if (!quote) {
    const char first = value.front();
    quote = std::isdigit(static_cast<unsigned char>(first)) || first == '-' || first == '.' ||
            first == '+';
    for (const char* reserved : kReserved) quote = quote || value == reserved;
  }
  return quote ? "\"" + value + "\"" : value;
}

namespace {

constexpr size_t kLineWidth = 100;
constexpr size_t kCommentColumn = 28;

struct YamlNode {
  std::string name;
  bool is_map = false;
  std::string value;
  std::string doc;
  std::vector<std::string> headings;
  std::vector<std::unique_ptr<YamlNode>> children;
};

YamlNode* child(YamlNode* parent, const std::string& name, bool is_map,
                std::vector<std::string>* pending_headings) {
  for (auto& existing : parent->children) {
    if (existing->name == name) return existing.get();
  }
  parent->children.push_back(std::make_unique<YamlNode>());
  YamlNode* created = parent->children.back().get();
  created->name = name;
  created->is_map = is_map;
  created->headings = std::move(*pending_headings);
  pending_headings->clear();
  return created;
}

YamlNode* insert(YamlNode* root, const std::string& key, bool leaf_is_map,
                 std::vector<std::string>* pending_headings) {
  YamlNode* node = root;
  std::istringstream parts(key);
  std::string part;
  std::vector<std::string> names;
  while (std::getline(parts, part, '/')) names.push_back(part);
  for (size_t i = 0; i < names.size(); ++i) {
    const bool is_map = i + 1 < names.size() || leaf_is_map;
    node = child(node, names[i], is_map, pending_headings);
  }
  return node;
}

/// Words of `text` in lines that fit after `indent` columns.
std::vector<std::string> wrap(const std::string& text, size_t indent) {
  const size_t width = kLineWidth > indent + 20 ? kLineWidth - indent : 20;
  std::vector<std::string> lines;
  std::istringstream words(text);
  std::string word;
  std::string line;
  while (words >> word) {
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      lines.push_back(line);
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

void renderNode(const YamlNode& node, size_t depth, std::ostringstream* out) {
  const std::string indent(2 * depth, ' ');
  for (const std::string& heading : node.headings) {
    *out << "\n";
    bool first = true;
    for (const std::string& line : wrap(heading, indent.size() + 6)) {
      *out << indent << (first ? "# --- " : "#     ") << line << "\n";
      first = false;
    }
  }
  // Maps stand apart: at the top, and the stages inside `advanced`.
  if (depth <= 1 && node.is_map && node.headings.empty()) *out << "\n";
  std::string head = indent + node.name + ":" + (node.is_map ? "" : " " + node.value);
  if (node.doc.empty()) {
    *out << head << "\n";
  } else {
    const size_t column = std::max(kCommentColumn, head.size() + 1);
    bool first = true;
    for (const std::string& line : wrap(node.doc, column + 2)) {
      if (first) {
        *out << head << std::string(column - head.size(), ' ') << "# " << line << "\n";
      } else {
        *out << std::string(column, ' ') << "# " << line << "\n";
      }
      first = false;
    }
  }
  for (const auto& child_node : node.children) renderNode(*child_node, depth + 1, out);
}

}  // namespace

std::string renderParameterYaml(const std::vector<DocumentedParameter>& parameters,
                                const std::string& preamble) {
  YamlNode root;
  std::vector<std::string> pending_headings;
  for (const DocumentedParameter& parameter : parameters) {
    if (parameter.evaluation_only) continue;
    switch (parameter.kind) {
      case DocumentedParameter::Kind::kSection:
        pending_headings.push_back(parameter.doc);
        break;
      case DocumentedParameter::Kind::kMap:
        insert(&root, parameter.key, true, &pending_headings)->doc = parameter.doc;
        break;
      case DocumentedParameter::Kind::kValue: {
        YamlNode* node = insert(&root, parameter.key, false, &pending_headings);
        node->value = parameter.value;
        node->doc = parameter.doc;
        break;
      }
    }
  }
  std::ostringstream out;
  for (const std::string& line : wrap(preamble, 2)) out << "# " << line << "\n";
  for (const auto& node : root.children) renderNode(*node, 0, &out);
  return out.str();
}

}  // namespace landmark_loop_closure
