// --set KEY=VALUE for a command that takes one part of the options tree
// (engine/pipeline/pipeline_options.h): dypho map takes mapper.*, dypho
// track tracker.*.
#pragma once

#include <string>
#include <vector>

#include "common/check.h"
#include "engine/pipeline/pipeline_options.h"

namespace dypho::tools {

// Applies each "PREFIX.KEY=VALUE" of `sets` to `*value`, the tree's `part`
// (for example &PipelineOptions::mapper with prefix "mapper."). A key
// outside the part, unknown or out of range throws InvalidInput naming it.
template <typename T>
void ApplyPartSets(const std::vector<std::string>& sets, const std::string& prefix, T PipelineOptions::*part,
                   T* value, const std::string& command) {
  if (sets.empty()) return;
  PipelineOptions tree;
  tree.*part = *value;
  for (const std::string& s : sets) {
    DYPHO_CHECK_INPUT(s.rfind(prefix, 0) == 0)
        << "--set " << s << ": " << command << " takes only " << prefix << "* keys (see dypho run --print-config)";
    SetOptionAssignment(&tree, s);
  }
  *value = tree.*part;
}

}  // namespace dypho::tools
