#include "engine/pipeline/config_tree.h"

#include <algorithm>

#include "common/check.h"

namespace dypho {

void FlattenConfig(const YAML::Node& node, const std::string& prefix,
                   std::vector<std::pair<std::string, std::string>>* out, const std::string& origin, int depth) {
  DYPHO_CHECK_INPUT(depth <= kMaxConfigDepth)
      << origin << ": sections nested deeper than " << kMaxConfigDepth << " levels (at '" << Printable(prefix) << "')";
  DYPHO_CHECK_INPUT(out->size() <= 10000) << origin << ": more than 10000 keys (an alias bomb?)";
  if (node.IsMap()) {
    for (const auto& kv : node) {
      DYPHO_CHECK_INPUT(kv.first.IsScalar()) << origin << ": " << Printable(prefix) << ": a key must be a plain name";
      const std::string key = kv.first.as<std::string>();
      const std::string full = prefix.empty() ? key : prefix + "." + key;
      // A section may open twice (the printed tree does so); a value may not be given twice.
      for (const auto& [seen, value] : *out) {
        DYPHO_CHECK_INPUT(seen != full || kv.second.IsMap())
            << origin << ": key '" << Printable(full) << "' is given twice (which one should win?)";
      }
      FlattenConfig(kv.second, full, out, origin, depth + 1);
    }
  } else if (node.IsSequence()) {
    std::string joined;
    for (const auto& item : node) {
      DYPHO_CHECK_INPUT(item.IsScalar()) << origin << ": " << prefix << ": list items must be scalars";
      joined += (joined.empty() ? "" : ",") + item.as<std::string>();
    }
    out->push_back({prefix, joined});
  } else if (node.IsScalar()) {
    out->push_back({prefix, node.as<std::string>()});
  } else {
    DYPHO_CHECK_INPUT(prefix.empty()) << origin << ": " << prefix << " has no value";
  }
}

void CheckConfigNesting(const std::string& text, const std::string& origin) {
  int depth = 0, max_depth = 0;
  char quote = 0;
  for (char c : text) {
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '[' || c == '{') {
      max_depth = std::max(max_depth, ++depth);
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  DYPHO_CHECK_INPUT(max_depth <= kMaxConfigDepth)
      << origin << ": lists or maps nested " << max_depth << " deep; options nest at most " << kMaxConfigDepth;
}

}  // namespace dypho
