// RGB-D sequences on disk: TUM RGB-D, Bonn RGB-D Dynamic, and generic
// folders in the same layout with a camera file (e.g. the synthetic
// generator's output or a user's own recording).
//
// Folder layout (paths in the lists are relative to the folder):
//   rgb.txt           "timestamp path" per line, '#' comments; timestamps
//                     strictly increasing. Absent: the images in rgb/ are
//                     used, their timestamps parsed from the file names
//                     ("1305031229.528748.png"); other names (such as frame
//                     numbers "000042.png") are sorted and stamped
//                     index / frame_rate, and depth/ images are then paired
//                     with RGB images of the same name.
//   depth.txt         the same for the 16-bit depth PNGs (absent: depth/).
//   associations.txt  optional "t_rgb rgb_path t_depth depth_path" lines; when
//                     present it pairs RGB and depth, and RGB frames it does
//                     not list have no depth. Otherwise each RGB frame gets
//                     the depth image nearest in time within max_depth_dt
//                     (greedy, one-to-one, as TUM's associate.py).
//   groundtruth.txt   optional "timestamp tx ty tz qx qy qz qw" world_from_cam
//                     poses; interpolated at the RGB timestamps (linear
//                     position, slerp rotation). Frames outside its time range
//                     (or inside a gap longer than max_gt_gap) get no pose and
//                     are listed by frames_without_gt().
//   masks/            optional 8-bit PNGs named like the RGB images (255 =
//                     dynamic), e.g. from the synthetic generator.
//   camera.yaml|.yml|.json  optional camera file (format in camera_file.h).
//
// Camera: DatasetOptions::camera_file, else DatasetOptions::camera_preset,
// else a camera file in the folder, else the preset named by the folder name
// (freiburg1/fr1, freiburg2/fr2, freiburg3/fr3, bonn). Images keep their
// lens distortion; the camera carries the distortion coefficients.
//
// Errors (missing folder, malformed or unsorted list, a listed image that
// does not exist or decode, 8-bit depth, RGB/depth/mask size mismatch) throw
// InvalidInput naming the file and, for list entries, the list file and line.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"
#include "engine/eval/trajectory.h"

namespace dypho {
namespace stereo {
struct StereoRig;
}

struct DatasetOptions {
  std::string camera_preset;    // "" = auto; freiburg1|fr1|freiburg2|fr2|freiburg3|fr3|bonn
  std::string camera_file;      // "" = auto; a YAML/JSON camera file (overrides everything)
  double depth_factor = 0.0;    // [depth units per metre]; 0 = camera file's value, else 5000
  double max_depth_dt = 0.02;   // [s] largest RGB-depth time difference when associating by time
  double max_gt_gap = 0.5;      // [s] longest ground-truth gap that is interpolated across
  double frame_rate = 30.0;     // [Hz] for image folders whose file names are not timestamps
  bool check_files = true;      // check at open that every listed image file exists
  bool parallel_decode = true;  // Load decodes the RGB and depth PNGs on two threads
  std::string stereo_method = "elas";  // stereo layouts: disparity method, elas or sgbm
  // When each depth image was captured (FrameInfo::depth_timestamp):
  // "auto" = the camera preset's offset from the colour timestamp where it
  // has one (PresetDepthTimeOffset: freiburg1 -0.020 s), else the listed depth
  // timestamps; "listed" = the listed depth timestamps; or an offset [s] from
  // the colour timestamp ("-0.02"; |offset| <= 0.1 s).
  std::string depth_time = "auto";

  bool IsValid(std::string* error) const;
};

// A frame's metadata, without pixels.
struct FrameInfo {
  size_t index = 0;                          // position in the sequence
  double timestamp = 0.0;                    // [s] RGB timestamp
  std::string rgb_path;                      // path of the RGB image (folder + listed path)
  std::string depth_path;                    // path of the depth image; empty without depth
  // [s] when the depth image was captured (valid with has_depth): the listed
  // depth timestamp, or the colour timestamp plus the dataset's depth time
  // offset (DatasetOptions::depth_time).
  double depth_timestamp = 0.0;
  double depth_listed_timestamp = 0.0;       // [s] the depth image's timestamp as listed
  bool has_depth = false;                    // whether a depth image is paired with it
  std::string mask_path;                     // path of the dynamic mask; empty without one
  std::optional<Rigid3d> world_from_cam_gt;  // interpolated ground truth, if covered
  std::string rgb_source;                    // where the RGB image is listed, "rgb.txt:12"
  std::string right_path;                    // stereo: the right image (depth comes from the pair)
  std::string depth_source;                  // where the depth image is listed
};

// A loaded frame.
struct Frame {
  size_t index = 0;                          // position in the sequence
  double timestamp = 0.0;                    // [s] RGB timestamp
  std::string rgb_path;                      // path of the RGB image
  std::string depth_path;                    // path of the depth image; empty without depth
  double depth_timestamp = 0.0;              // [s] when the depth was captured (FrameInfo::depth_timestamp)
  ImageU8 rgb;                               // RGB, 3 channels
  ImageF depth;                              // [m], 1 channel, 0 = invalid; empty without depth
  bool has_depth = false;                    // whether `depth` holds an image
  std::optional<Rigid3d> world_from_cam_gt;  // ground-truth pose, if covered
  ImageU8 dynamic_mask;                      // 1 channel, 255 = dynamic; empty if none
  ImageU8 right;                             // stereo: the rectified right image (RGB); else empty
  // Stereo: `depth` is a preview from the disparity of the pair at 1/n of
  // the resolution when n > 1 (StereoRig::preview_downscale); 1 = full.
  int depth_downscale = 1;
  double disparity_ms = 0.0;                 // stereo: wall time of the frame loader's disparity [ms]
};

class Dataset {
 public:
  // What OpenDataset found; public so that tests and tools can build one.
  struct Contents {
    std::string folder;             // dataset folder as given
    std::string name;               // folder name
    std::string format;             // "tum", "bonn" or "generic"
    Camera camera;                  // intrinsics (with distortion, if any)
    std::string camera_source;      // where the camera came from, e.g. "preset freiburg1 (folder name)"
    double depth_factor = 5000.0;   // [depth units per metre]
    std::vector<FrameInfo> frames;  // in time order
    // How FrameInfo::depth_timestamp was set: "listed", or "colour time
    // -0.020 s (preset freiburg1)" and the like.
    std::string depth_time_source = "listed";
    Trajectory ground_truth;        // as read from groundtruth.txt (may be empty)
    std::string ground_truth_path;  // empty without ground truth
    bool parallel_decode = true;    // Load decodes RGB and depth concurrently
    // Stereo layouts (engine/stereo/stereo_dataset.h): the rectified rig; Load
    // then reads the pair and computes depth from dense disparity.
    std::shared_ptr<const stereo::StereoRig> stereo;
  };

  explicit Dataset(Contents contents);

  size_t size() const { return contents_.frames.size(); }
  const Camera& camera() const { return contents_.camera; }
  double depth_factor() const { return contents_.depth_factor; }
  const std::string& name() const { return contents_.name; }
  const std::string& folder() const { return contents_.folder; }
  const std::string& format() const { return contents_.format; }
  const std::string& camera_source() const { return contents_.camera_source; }
  const std::string& depth_time_source() const { return contents_.depth_time_source; }
  const stereo::StereoRig* stereo() const { return contents_.stereo.get(); }
  const std::vector<FrameInfo>& frames() const { return contents_.frames; }
  const FrameInfo& info(size_t i) const;
  const Trajectory& ground_truth() const { return contents_.ground_truth; }
  bool has_ground_truth() const { return !contents_.ground_truth.empty(); }
  // Indices of frames without a ground-truth pose (all frames when the
  // dataset has no ground truth).
  const std::vector<size_t>& frames_without_gt() const { return frames_without_gt_; }
  size_t frames_with_depth() const;
  size_t frames_with_mask() const;

  // Reads and decodes frame i (thread-safe: reads files only). Throws
  // InvalidInput naming the file and its list entry on a missing or corrupt
  // image, 8-bit depth, or a size mismatch with the camera or the RGB image.
  Frame Load(size_t i) const;
  // A copy of a stereo dataset whose frame loader makes preview depths from
  // the pair downscaled by `downscale` (StereoRig::preview_downscale; 1 =
  // the full dense depth). Throws InvalidInput for a non-stereo dataset or
  // a downscale outside 1..8.
  Dataset WithStereoPreview(int downscale) const;

 private:
  Contents contents_;
  std::vector<size_t> frames_without_gt_;
};

// Opens the dataset in `folder` (layout and camera rules above). Lists are
// parsed and image files checked for existence; pixels are read by Load.
std::unique_ptr<Dataset> OpenDataset(const std::string& folder,
                                     const DatasetOptions& options = DatasetOptions());

// The ground-truth pose at time t [s]: linear interpolation of the position
// and slerp of the rotation between the two samples around t. nullopt when t
// lies outside [first, last] timestamp or between samples more than
// `max_gap` [s] apart.
std::optional<Rigid3d> InterpolatePose(const Trajectory& trajectory, double t, double max_gap);

}  // namespace dypho
