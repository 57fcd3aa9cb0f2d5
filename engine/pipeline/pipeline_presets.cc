// The presets of the options tree (engine/pipeline/pipeline_options.h): each
// one is YAML applied on top of the defaults.
#include <yaml-cpp/yaml.h>

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "common/check.h"
#include "engine/pipeline/config_tree.h"
#include "engine/pipeline/pipeline_options.h"

namespace dypho {

namespace {

// Each preset as YAML on top of the defaults.
const std::map<std::string, std::string>& Presets() {
  static const std::map<std::string, std::string> presets = {
      {"synthetic",
       "# The built-in synthetic dynamic sequence (exact depth model, no lens distortion).\n"
       "preset: synthetic\nrolling_shutter: 0\nsemantic_dataset_masks: true\n"
       "masking:\n  schedule:\n    interval: 5\n"},
      {"tum",
       "# TUM RGB-D (Kinect v1): rolling shutter, person detector every 5 frames, masks at 320x240, map depth at\n"
       "# 160x120 every 4 frames; keyframes that wait are packed (none is dropped) and mapped after the last\n"
       "# frame, then up to 3000 steps over all keyframes until the held-back frames stop improving or\n"
       "# finish_seconds after the last frame (4 minutes). The tracker models the rolling shutter; the mapper\n"
       "# does not by default (map_sensor_model: a sharper map, but plain renders score lower against the\n"
       "# blurred frames of fast rotation, BENCHMARKS.md). The mapper refines the keyframes' poses against the\n"
       "# map and the other frames follow them (engine/map/trajectory_follow.h): +0.4 dB on novel views of\n"
       "# tum_fr1_rpy_head250 and its walker composites, depth L1 0.2-0.3 cm lower. A keyframe is due after 10\n"
       "# degrees of rotation (15 elsewhere): fr1's hand-held rotation left views between keyframes that the map\n"
       "# covered with holes; 26 keyframes instead of 22 on head250, +0.4 to +0.6 dB on its novel views.\n"
       "preset: tum\nrolling_shutter: 0.025\nrender_downscale: 4\nrender_every: 4\nmasking_downscale: 2\n"
       "queue_capacity: 8\nfinal_iterations: 3000\nfinish_seconds: 240\nmapper:\n  refine_poses: true\n"
       "  sensor:\n    exposure: 0.015\n"
       "keyframes:\n  max_rotation_deg: 10\n"
       "masking:\n  schedule:\n    interval: 5\n"},
      {"bonn",
       "# Bonn RGB-D Dynamic (ASUS Xtion, global shutter): people and balloons move fast.\n"
       "preset: bonn\nrolling_shutter: 0\nrender_downscale: 4\nmasking:\n  schedule:\n    interval: 3\n"
       "  segmenter:\n    classes: person,sports ball,kite\n"},
      {"stereo",
       "# Stereo cameras outdoors (KITTI odometry, EuRoC, generic stereo folders): depth from dense disparity,\n"
       "# trusted to 25 m; keyframes create map points nearer than 15 m (28 baselines at KITTI's 0.54 m; on\n"
       "# kitti_stereo_51 12 m gave 0.8 % ATE, 15 m 1.05 %, 20 m 1.3 %, 10 m lost frames); keyframes every metre;\n"
       "# a vehicle drives on, so after 2 lost frames a new map starts where the motion leads; the dense map\n"
       "# keeps 1-25 m in 10 cm voxels (the indoor 0.1-4 m default left it nearly empty on KITTI).\n"
       "# Dynamic masks as in the nearshore stereo system: the detector (--model) and the epipolar check, no\n"
       "# flow-motion mask (on kitti_stereo_51 it marked the near road's painted hatching as moving: ATE\n"
       "# 0.90-0.93 % of the path without it, 0.96-1.04 % with it; and 7 ms a frame less).\n"
       "# The tracker searches its features' matches around the preview disparity (no right-image features,\n"
       "# 10-13 ms a frame less) and its coarse step also matches 200 temporary points of the last frame\n"
       "# (without them the prior search lost frames on kitti_stereo_51; BENCHMARKS.md).\n"
       "preset: stereo\nrolling_shutter: 0\nrender_downscale: 4\nmasking_downscale: 2\n"
       "keyframes:\n  max_translation: 1.0\n"
       "mapper:\n  min_depth: 1\n  max_depth: 25\n"
       "dense:\n  points:\n    min_depth: 1\n    max_depth: 25\n  map:\n    voxel_size: 0.1\n"
       "stereo_prior_tracking: true\n"
       "tracker:\n  min_depth: 1\n  max_depth: 25\n  close_depth: 15\n  restart_after_lost: 2\n  last_frame_points: 200\n"
       "  extractor:\n    num_features: 2000\n"
       "masking:\n  use_flow: false\n  schedule:\n    interval: 3\n"},
      {"shore",
       "# Nearshore (boats, docks): water and sky are masked, boats are the dynamic class.\n"
       "preset: shore\nrolling_shutter: 0\nmasking:\n  use_shore: true\n  segmenter:\n    classes: person,boat\n"
       "# The tracker trusts depth to 30 m and makes map points nearer than 20 m: on the synthetic harbour (quay at\n"
       "# 9 m, buildings at 16-25 m) 10/20 m left too few points (ATE 38 cm) where 20/30 m gives 5.9 cm.\n"
       "mapper:\n  max_depth: 30\ntracker:\n  max_depth: 30\n  close_depth: 20\n"
       "# Without a dataset: the synthetic harbour (dypho synth --scene shore); without a detector model its\n"
       "# masks/ (pedestrians and the boat) stand in for the detector, as in the synthetic preset.\n"
       "semantic_dataset_masks: true\n"
       "synth:\n  scene: shore\n  width: 320\n  height: 240\n  frames: 100\n  fps: 15\n  num_walkers: 3\n  seed: 1\n"},
  };
  return presets;
}

}  // namespace

std::vector<std::string> PresetNames() {
  std::vector<std::string> names;
  for (const auto& [name, text] : Presets()) names.push_back(name);
  return names;
}

std::string PresetText(const std::string& name) {
  const auto it = Presets().find(name);
  std::string list;
  for (const auto& n : PresetNames()) list += (list.empty() ? "" : "|") + n;
  DYPHO_CHECK_INPUT(it != Presets().end()) << "preset: '" << name << "' is not one of " << list;
  return it->second;
}

PipelineOptions PresetOptions(const std::string& name) {
  PipelineOptions options;
  const std::string text = PresetText(name);
  // The preset text has no nested preset key handling issue: apply its keys.
  YAML::Node root = YAML::Load(text);
  std::vector<std::pair<std::string, std::string>> keys;
  FlattenConfig(root, "", &keys, "preset " + name);
  for (const auto& [key, value] : keys) SetOption(&options, key, value, "preset " + name);
  return options;
}

}  // namespace dypho
