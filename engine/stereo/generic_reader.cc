// The generic stereo layout: left/, right/, stereo.yaml (see stereo_dataset.h).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

#include <yaml-cpp/yaml.h>

#include "common/check.h"
#include "engine/eval/trajectory.h"
#include "engine/stereo/stereo_dataset.h"

namespace dypho::stereo {
namespace fs = std::filesystem;
namespace {

std::string At(const std::string& file, const YAML::Node& node) {
  return file + ":" + std::to_string(node.Mark().line + 1);
}

double Number(const YAML::Node& node, const std::string& key, const std::string& file, const YAML::Node& parent) {
  DYPHO_CHECK_INPUT(node) << At(file, parent) << ": missing '" << key << "'";
  double x = 0;
  try {
    x = node.as<double>();
  } catch (const YAML::Exception&) {
    throw InvalidInput(At(file, node) + ": '" + key + "' is not a number");
  }
  DYPHO_CHECK_INPUT(std::isfinite(x)) << At(file, node) << ": '" << key << "' is not finite";
  return x;
}

std::vector<double> List(const YAML::Node& parent, const std::string& key, size_t count, const std::string& file) {
  const YAML::Node node = parent[key];
  DYPHO_CHECK_INPUT(node && node.IsSequence()) << At(file, parent) << ": missing list '" << key << "'";
  DYPHO_CHECK_INPUT(node.size() == count)
      << At(file, node) << ": '" << key << "' needs " << count << " numbers, found " << node.size();
  std::vector<double> v;
  for (size_t i = 0; i < node.size(); ++i) v.push_back(Number(node[i], key, file, node));
  return v;
}

Camera ReadCamera(const YAML::Node& root, const std::string& key, const std::string& file) {
  const YAML::Node node = root[key];
  DYPHO_CHECK_INPUT(node && node.IsMap()) << file << ": missing camera '" << key << "'";
  Camera c;
  c.fx = Number(node["fx"], key + ".fx", file, node);
  c.fy = Number(node["fy"], key + ".fy", file, node);
  c.cx = Number(node["cx"], key + ".cx", file, node);
  c.cy = Number(node["cy"], key + ".cy", file, node);
  c.width = int(Number(root["width"], "width", file, root));
  c.height = int(Number(root["height"], "height", file, root));
  if (node["distortion"]) {
    const std::vector<double> d = List(node, "distortion", node["distortion"].size(), file);
    DYPHO_CHECK_INPUT(d.size() == 4 || d.size() == 5)
        << At(file, node["distortion"]) << ": '" << key << ".distortion' needs 4 or 5 numbers";
    for (size_t k = 0; k < d.size(); ++k) c.distortion[k] = d[k];
  }
  return c;
}

}  // namespace

namespace internal {

std::optional<Dataset::Contents> OpenGenericStereo(const std::string& folder, const DatasetOptions& options) {
  const fs::path root(folder), yaml = root / "stereo.yaml";
  if (!fs::exists(yaml)) return std::nullopt;
  const std::string file = yaml.string();
  YAML::Node y;
  try {
    y = YAML::LoadFile(file);
  } catch (const YAML::Exception& e) {
    throw InvalidInput(file + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  DYPHO_CHECK_INPUT(y.IsMap()) << file << ": a map of keys is expected";
  StereoCalibration s;
  s.source = file;
  s.left = ReadCamera(y, "left", file);
  s.right = ReadCamera(y, "right", file);
  const YAML::Node t = y["right_from_left"];
  DYPHO_CHECK_INPUT(t && t.IsMap()) << file << ": missing 'right_from_left'";
  const std::vector<double> r = List(t, "rotation", 9, file), tr = List(t, "translation", 3, file);
  for (int k = 0; k < 9; ++k) s.right_from_left_rotation(k / 3, k % 3) = r[k];
  s.right_from_left_translation = Eigen::Vector3d(tr[0], tr[1], tr[2]);
  const Eigen::Matrix3d& R = s.right_from_left_rotation;
  DYPHO_CHECK_INPUT((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-4 &&
                    R.determinant() > 0)
      << At(file, t["rotation"]) << ": right_from_left.rotation is not a rotation";
  {
    s.source = At(file, t["translation"]);
    auto rig = std::make_shared<StereoRig>(MakeRig(s));
    s.source = file;
    const double frame_rate = y["frame_rate"] ? Number(y["frame_rate"], "frame_rate", file, y) : 30.0;
    DYPHO_CHECK_INPUT(frame_rate > 0) << At(file, y["frame_rate"]) << ": frame_rate must be > 0";

    DYPHO_CHECK_INPUT(fs::is_directory(root / "left")) << (root / "left").string() << ": missing";
    DYPHO_CHECK_INPUT(fs::is_directory(root / "right")) << (root / "right").string() << ": missing";
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(root / "left")) {
      const std::string ext = e.path().extension().string();
      if (e.is_regular_file() && (ext == ".png" || ext == ".jpg" || ext == ".pgm" || ext == ".ppm"))
        names.push_back(e.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    DYPHO_CHECK_INPUT(!names.empty()) << (root / "left").string() << ": no images";
    Dataset::Contents c;
    c.folder = folder;
    c.name = fs::absolute(root).lexically_normal().filename().string();
    c.format = "stereo";
    c.camera = rig->camera;
    c.camera_source = file + (rig->rectify ? " (rectified here)" : " (already rectified)");
    for (size_t i = 0; i < names.size(); ++i) {
      FrameInfo f;
      f.index = i;
      f.timestamp = i / frame_rate;
      f.rgb_path = (root / "left" / names[i]).string();
      f.right_path = (root / "right" / names[i]).string();
      f.rgb_source = "left/" + names[i];
      f.has_depth = true;
      c.frames.push_back(f);
    }
    CheckPairsExist(c);
    const fs::path gt = root / "groundtruth.txt";
    if (fs::exists(gt)) {
      c.ground_truth = ReadTumTrajectory(gt.string());
      c.ground_truth_path = gt.string();
      // world_from_left -> world_from_rectified_left.
      const Rigid3d left_from_rectified(Eigen::Quaterniond(rig->rectified_from_left.transpose()),
                                        Eigen::Vector3d::Zero());
      for (Rigid3d& pose : c.ground_truth.world_from_cam) pose = pose * left_from_rectified;
      for (FrameInfo& f : c.frames) f.world_from_cam_gt = InterpolatePose(c.ground_truth, f.timestamp, options.max_gt_gap);
    }
    c.stereo = rig;
    return c;
  }
}

}  // namespace internal
}  // namespace dypho::stereo
