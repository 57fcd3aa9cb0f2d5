#include "engine/pipeline/pipeline_options.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <sstream>

#include "common/check.h"
#include "common/files.h"
#include "engine/pipeline/config_tree.h"
#include "engine/pipeline/option_table.h"

namespace dypho {

using option_table::FormatDouble;
using option_table::Trim;

void SetOption(PipelineOptions* options, const std::string& key, const std::string& value,
               const std::string& origin) {
  const std::string where = origin.empty() ? "" : origin + ": ";
  std::vector<OptionInfo> table = DescribeOptions(options);
  for (OptionInfo& info : table) {
    if (info.key != key) continue;
    try {
      info.set(value);
    } catch (const InvalidInput& e) {
      throw InvalidInput(where + e.message(), e.location());
    }
    return;
  }
  // A near miss helps with typos: the known keys sharing the section.
  std::string hint;
  const std::string section = key.substr(0, key.rfind('.') == std::string::npos ? 0 : key.rfind('.') + 1);
  int shown = 0;
  for (const OptionInfo& info : table) {
    if (!section.empty() && info.key.rfind(section, 0) == 0 && shown < 6) {
      hint += (shown++ ? ", " : "") + info.key;
    }
  }
  DYPHO_CHECK_INPUT(false) << where << "unknown key '" << key << "'"
                           << (hint.empty() ? " (dypho run --print-config lists every key)"
                                            : " (keys in that section: " + hint + ", ...)");
}

void SetOptionAssignment(PipelineOptions* options, const std::string& assignment) {
  const size_t eq = assignment.find('=');
  DYPHO_CHECK_INPUT(eq != std::string::npos && eq > 0)
      << "--set '" << assignment << "': expected key=value (e.g. masking.flow.scale=0.25)";
  SetOption(options, Trim(assignment.substr(0, eq)), assignment.substr(eq + 1), "--set");
}

void ApplyConfigText(PipelineOptions* options, const std::string& text, const std::string& origin) {
  CheckConfigNesting(text, origin);
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    DYPHO_CHECK_INPUT(false) << origin << ": not valid YAML/JSON: " << Printable(e.what(), 200);
  }
  if (root.IsNull()) return;
  DYPHO_CHECK_INPUT(root.IsMap()) << origin << ": the top level must be a map of keys";
  std::vector<std::pair<std::string, std::string>> keys;
  FlattenConfig(root, "", &keys, origin);
  for (const auto& [key, value] : keys) {
    if (key == "preset") *options = PresetOptions(Trim(value));
  }
  for (const auto& [key, value] : keys) {
    if (key != "preset") SetOption(options, key, value, origin);
  }
}

void ApplyConfigFile(PipelineOptions* options, const std::string& path) {
  ApplyConfigText(options, ReadTextFile(path), path);
}

std::string FormatOptions(PipelineOptions options) {
  const PipelineOptions defaults = PresetOptions(options.preset);
  std::vector<OptionInfo> table = DescribeOptions(&options);
  std::ostringstream out;
  out << "# dypho run options (every key; defaults of preset '" << options.preset << "' unless marked)\n";
  std::vector<std::string> open;  // current section path
  PipelineOptions d = defaults;
  std::vector<OptionInfo> dtable = DescribeOptions(&d);
  for (size_t i = 0; i < table.size(); ++i) {
    const OptionInfo& info = table[i];
    std::vector<std::string> parts;
    std::stringstream ss(info.key);
    std::string part;
    while (std::getline(ss, part, '.')) parts.push_back(part);
    const std::vector<std::string> sections(parts.begin(), parts.end() - 1);
    size_t common = 0;
    while (common < open.size() && common < sections.size() && open[common] == sections[common]) ++common;
    for (size_t s = common; s < sections.size(); ++s) out << std::string(2 * s, ' ') << sections[s] << ":\n";
    open = sections;
    std::string value = info.get();
    if (info.type == "string" || info.type == "list") value = "\"" + value + "\"";
    out << std::string(2 * sections.size(), ' ') << parts.back() << ": " << value << "  # ";
    if (!info.units.empty()) out << "[" << info.units << "] ";
    if (info.has_range) {
      out << "range [" << FormatDouble(info.min) << ", " << FormatDouble(info.max) << "] ";
    }
    out << info.doc;
    if (dtable[i].get() != info.get()) out << " (default " << dtable[i].get() << ")";
    out << "\n";
  }
  return out.str();
}

std::vector<std::string> AblationSwitches() {
  return {"refine", "adaptive", "semantic", "flow", "epipolar", "shore", "masking", "local-ba", "loops"};
}

void DisableStage(PipelineOptions* options, const std::string& stage) {
  if (stage == "refine") {
    options->masking.use_background = false;
  } else if (stage == "adaptive") {
    options->tracker.extractor.adaptive_threshold = false;
  } else if (stage == "semantic") {
    options->semantic = false;
  } else if (stage == "flow") {
    options->masking.use_flow = false;
  } else if (stage == "epipolar") {
    options->masking.use_epipolar = false;
  } else if (stage == "shore") {
    options->masking.use_shore = false;
  } else if (stage == "local-ba") {
    options->tracker.local_ba.enabled = false;
  } else if (stage == "loops") {
    options->tracker.loops.enabled = false;
  } else if (stage == "masking") {
    for (const char* s : {"refine", "adaptive", "semantic", "flow", "epipolar", "shore"}) DisableStage(options, s);
  } else {
    std::string list;
    for (const auto& s : AblationSwitches()) list += (list.empty() ? "" : "|") + s;
    DYPHO_CHECK_INPUT(false) << "--disable: '" << stage << "' is not one of " << list;
  }
}

void PipelineOptions::Validate() const {
  PipelineOptions copy = *this;
  // Table ranges: re-set every value from its own text.
  for (OptionInfo& info : DescribeOptions(&copy)) info.set(info.get());
  std::string error;
  DYPHO_CHECK_INPUT(masking.IsValid(&error)) << "masking." << error;
  DYPHO_CHECK_INPUT(tracker.IsValid(&error)) << "tracker." << error;
  try {
    mapper.Validate();
    keyframes.Validate();
  } catch (const InvalidInput& e) {
    throw InvalidInput("mapper/keyframes: " + e.message(), e.location());
  }
  DYPHO_CHECK_INPUT(frame_prior.IsValid(&error)) << "frame_prior." << error;
  SynthOptions s = synth;
  DYPHO_CHECK_INPUT(ParseSynthMotion(synth_motion, &s.motion)) << "synth.motion: '" << synth_motion << "' is unknown";
  DYPHO_CHECK_INPUT(s.IsValid(&error)) << "synth." << error;
  DYPHO_CHECK_INPUT(max_mask_age == 0 || max_mask_age >= masking.schedule.interval)
      << "max_mask_age: " << max_mask_age << " is below masking.schedule.interval (" << masking.schedule.interval
      << "): masks of a detector run every " << masking.schedule.interval << " frames get older (0 = no bound)";
  DYPHO_CHECK_INPUT(MaskLagForAge(max_mask_age, masking.schedule.interval) <= masking.schedule.max_carry_frames)
      << "max_mask_age: " << max_mask_age << " needs masks carried further than masking.schedule.max_carry_frames ("
      << masking.schedule.max_carry_frames << ")";
}

}  // namespace dypho
