// Camera intrinsics for datasets: the built-in presets (TUM RGB-D freiburg1/2/3
// and Bonn RGB-D Dynamic) and the camera file of a generic folder.
//
// Camera file format (YAML `camera.yaml` / `camera.yml` or JSON `camera.json`,
// the same keys in both; one flat map):
//
//   fx: 517.3          # focal length x [px]            (required)
//   fy: 516.5          # focal length y [px]            (required)
//   cx: 318.6          # principal point x [px]         (required; pixel centres at integers)
//   cy: 255.3          # principal point y [px]         (required)
//   width: 640         # image width [px]               (required)
//   height: 480        # image height [px]              (required)
//   distortion: [0.2624, -0.9531, -0.0054, 0.0026, 1.1633]
//                      # optional k1 k2 p1 p2 [k3] (OpenCV radial-tangential
//                      # order; 4 or 5 values; default none)
//   depth_factor: 5000 # optional: depth PNG units per metre (default 5000,
//                      # the TUM convention; 1000 for millimetre depth)
//
// JSON: {"fx": 517.3, "fy": 516.5, "cx": 318.6, "cy": 255.3, "width": 640,
//        "height": 480, "distortion": [...], "depth_factor": 5000}
// Other keys are ignored with a warning. A missing or malformed key throws
// InvalidInput naming the file, the key and (YAML) the line.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"

namespace dypho {

// Depth units per metre in TUM and Bonn 16-bit depth PNGs.
inline constexpr double kTumDepthFactor = 5000.0;

// Canonical preset names: "freiburg1", "freiburg2", "freiburg3", "bonn".
std::vector<std::string> CameraPresetNames();
// The preset for a canonical name or an alias (fr1, fr2, fr3, tum1..3,
// case-insensitive); nullopt for an unknown name. All are 640x480.
std::optional<Camera> CameraPreset(const std::string& name);
// When the preset's sensor captures a depth image, as an offset [s] from the
// timestamp of the colour image it is paired with; nullopt where not known
// (the listed depth timestamps are used). freiburg1: -0.020 s, measured here
// (BENCHMARKS.md, "Depth capture time"): the Kinect's depth images of
// tum_fr1_rpy_head250 agree with each other best at the ground-truth poses
// 20 ms before their colour timestamps, although the lists put them 0-14 ms
// after.
std::optional<double> PresetDepthTimeOffset(const std::string& name);
// Canonical preset name for a name or alias, "" when unknown.
std::string CanonicalPresetName(const std::string& name);
// The preset named by a dataset folder's own name (its last path component):
// "freiburg1" if it contains "freiburg1" or "fr1", likewise 2 and 3, "bonn"
// if it contains "bonn" (case-insensitive). "" when none matches; throws
// InvalidInput when more than one preset matches.
std::string PresetFromFolderName(const std::string& folder);

struct CameraFile {
  Camera camera;
  std::optional<double> depth_factor;  // [units per metre] when the file gives it
};
// Reads a camera file (.yaml/.yml or .json, by extension) in the format above.
CameraFile ReadCameraFile(const std::string& path);
// The text of a YAML camera file for `camera` (as the synthetic generator
// or a user would write it).
std::string FormatCameraYaml(const Camera& camera, double depth_factor);

}  // namespace dypho
