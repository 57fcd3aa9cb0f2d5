// Option files (YAML, or JSON read as YAML) as a flat list of dotted keys
// and values: the part of engine/pipeline/pipeline_options.cc that reads
// outside text, with its limits on nesting, size and repeated keys.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace dypho {

// The deepest nesting of sections a config may have (the options tree has
// 4 levels; YAML itself would recurse until the stack ran out).
constexpr int kMaxConfigDepth = 16;

// Appends (key, value) for every scalar or list under `node` ("a.b.c",
// lists joined with commas). Throws InvalidInput naming `origin` for a value
// given twice (a section may open twice), nesting deeper than
// kMaxConfigDepth, more than 10000 keys, or a list of non-scalars.
void FlattenConfig(const YAML::Node& node, const std::string& prefix,
                   std::vector<std::pair<std::string, std::string>>* out, const std::string& origin, int depth = 0);

// Throws InvalidInput naming `origin` when flow-style lists or maps ([ and {,
// JSON's) nest deeper than kMaxConfigDepth; measured before parsing, since
// yaml-cpp gives up on deep nesting with only "bad file".
void CheckConfigNesting(const std::string& text, const std::string& origin);

}  // namespace dypho
