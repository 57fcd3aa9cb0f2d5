// Writing what `dypho map` produced: the map (3DGS PLY), the trajectory (TUM
// format), per-frame scores (CSV), a Markdown report with a loss plot and a
// grid of keyframe renders beside the real images (PNG).
#pragma once

#include <string>
#include <vector>

#include "engine/dataset/dataset.h"
#include "engine/map/map_sequence.h"
#include "engine/map/mapper.h"

namespace dypho {

// Every entry WriteMappingOutputs may write: `dypho map` clears them first.
inline const std::vector<std::string> kMappingOutputs = {"map.ply",  "trajectory.txt", "keyframes.txt", "scores.csv",
                                                         "report.md", "loss.png",      "renders.png",    "dense.ply"};

// Writes into `out_dir` (created): map.ply, dense.ply (when the dense map
// was built), trajectory.txt, scores.csv,
// report.md, loss.png, renders/kf_NNNNNN.png (render | real, a sample of
// keyframes). Every file is written atomically.
void WriteMappingOutputs(const std::string& out_dir, const Dataset& dataset, const SequenceMappingResult& result,
                         const Mapper& mapper, int max_renders = 8);

// A few lines: keyframes, Gaussians, time, PSNR/SSIM on keyframes and held-out frames.
std::string FormatMappingSummary(const SequenceMappingResult& result);

}  // namespace dypho
