// The EuRoC/ASL layout (see stereo_dataset.h).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "common/check.h"
#include "engine/stereo/stereo_dataset.h"

namespace dypho::stereo {
namespace fs = std::filesystem;
namespace {

std::string At(const std::string& file, const YAML::Node& node) {
  return file + ":" + std::to_string(node.Mark().line + 1);
}

std::vector<double> Doubles(const YAML::Node& root, const std::string& key, size_t count, const std::string& file) {
  const YAML::Node node = root[key];
  DYPHO_CHECK_INPUT(node && node.IsSequence()) << file << ": missing list '" << key << "'";
  DYPHO_CHECK_INPUT(node.size() >= count) << At(file, node) << ": '" << key << "' needs " << count << " numbers";
  std::vector<double> v;
  for (size_t i = 0; i < node.size(); ++i) {
    double x = 0;
    try {
      x = node[i].as<double>();
    } catch (const YAML::Exception&) {
      throw InvalidInput(At(file, node[i]) + ": '" + key + "' holds a non-number");
    }
    DYPHO_CHECK_INPUT(std::isfinite(x)) << At(file, node[i]) << ": non-finite number in '" << key << "'";
    v.push_back(x);
  }
  return v;
}

struct EurocCamera {
  Camera camera;
  Eigen::Matrix4d body_from_sensor = Eigen::Matrix4d::Identity();
};

EurocCamera ReadSensor(const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::Exception& e) {
    throw InvalidInput(file + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  EurocCamera c;
  const auto res = Doubles(root, "resolution", 2, file);
  const auto in = Doubles(root, "intrinsics", 4, file);
  const auto dist = Doubles(root, "distortion_coefficients", 4, file);
  c.camera.width = int(res[0]), c.camera.height = int(res[1]);
  c.camera.fx = in[0], c.camera.fy = in[1], c.camera.cx = in[2], c.camera.cy = in[3];
  for (size_t k = 0; k < std::min<size_t>(5, dist.size()); ++k) c.camera.distortion[k] = dist[k];
  const YAML::Node t = root["T_BS"];
  DYPHO_CHECK_INPUT(t) << file << ": missing 'T_BS'";
  const auto data = Doubles(t, "data", 16, file);
  for (int k = 0; k < 16; ++k) c.body_from_sensor(k / 4, k % 4) = data[k];
  return c;
}

// data.csv: "timestamp [ns],file name".
std::vector<std::pair<double, std::string>> ReadList(const std::string& file) {
  std::ifstream in(file);
  DYPHO_CHECK_INPUT(in.good()) << file << ": cannot be read";
  std::vector<std::pair<double, std::string>> rows;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t comma = line.find(',');
    DYPHO_CHECK_INPUT(comma != std::string::npos) << file << ":" << n << ": 'timestamp,file name' expected";
    char* end = nullptr;
    const double ns = std::strtod(line.c_str(), &end);
    DYPHO_CHECK_INPUT(end == line.c_str() + comma && std::isfinite(ns)) << file << ":" << n << ": bad timestamp";
    rows.emplace_back(ns * 1e-9, line.substr(comma + 1));
  }
  return rows;
}

}  // namespace

namespace internal {

std::optional<Dataset::Contents> OpenEuroc(const std::string& folder, const DatasetOptions& options) {
  const fs::path mav = fs::path(folder) / "mav0";
  if (!fs::is_directory(mav / "cam0")) return std::nullopt;
  DYPHO_CHECK_INPUT(fs::is_directory(mav / "cam1")) << (mav / "cam1").string() << ": missing (the right camera)";
  const std::string s0 = (mav / "cam0" / "sensor.yaml").string(), s1 = (mav / "cam1" / "sensor.yaml").string();
  const EurocCamera left = ReadSensor(s0), right = ReadSensor(s1);
  StereoCalibration s;
  s.source = s1;
  s.left = left.camera, s.right = right.camera;
  const Eigen::Matrix4d right_from_left = right.body_from_sensor.inverse() * left.body_from_sensor;
  s.right_from_left_rotation = right_from_left.topLeftCorner<3, 3>();
  s.right_from_left_translation = right_from_left.topRightCorner<3, 1>();
  auto rig = std::make_shared<StereoRig>(MakeRig(s));

  Dataset::Contents c;
  c.folder = folder;
  c.name = fs::absolute(fs::path(folder)).lexically_normal().filename().string();
  c.format = "euroc";
  c.camera = rig->camera;
  c.camera_source = s0 + " + " + s1 + (rig->rectify ? " (rectified here)" : "");
  const std::string list0 = (mav / "cam0" / "data.csv").string();
  const auto rows = ReadList(list0);
  DYPHO_CHECK_INPUT(!rows.empty()) << list0 << ": no frames";
  for (size_t i = 0; i < rows.size(); ++i) {
    FrameInfo f;
    f.index = i;
    f.timestamp = rows[i].first;
    f.rgb_path = (mav / "cam0" / "data" / rows[i].second).string();
    f.right_path = (mav / "cam1" / "data" / rows[i].second).string();
    f.rgb_source = list0 + ":" + std::to_string(i + 2);
    f.has_depth = true;
    c.frames.push_back(f);
  }
  CheckPairsExist(c);
  // Ground truth of the body -> the rectified left camera.
  const fs::path gt = mav / "state_groundtruth_estimate0" / "data.csv";
  if (fs::exists(gt)) {
    std::ifstream in(gt);
    std::string line;
    Rigid3d body_from_cam = Rigid3d::FromMatrix(left.body_from_sensor.topRows<3>());
    body_from_cam = body_from_cam * Rigid3d(Eigen::Quaterniond(rig->rectified_from_left.transpose()),
                                            Eigen::Vector3d::Zero());
    for (int n = 1; std::getline(in, line); ++n) {
      if (line.empty() || line[0] == '#') continue;
      std::replace(line.begin(), line.end(), ',', ' ');
      std::istringstream row(line);
      double v[8];
      for (double& x : v) row >> x;
      DYPHO_CHECK_INPUT(!row.fail()) << gt.string() << ":" << n << ": timestamp, position, quaternion expected";
      for (double x : v) DYPHO_CHECK_INPUT(std::isfinite(x)) << gt.string() << ":" << n << ": non-finite number";
      const Rigid3d world_from_body(Eigen::Quaterniond(v[4], v[5], v[6], v[7]), Eigen::Vector3d(v[1], v[2], v[3]));
      const double t = v[0] * 1e-9;
      DYPHO_CHECK_INPUT(c.ground_truth.empty() || t > c.ground_truth.timestamps.back())
          << gt.string() << ":" << n << ": timestamps must increase";
      c.ground_truth.Add(t, world_from_body * body_from_cam);
    }
    c.ground_truth_path = gt.string();
    for (FrameInfo& f : c.frames) f.world_from_cam_gt = InterpolatePose(c.ground_truth, f.timestamp, options.max_gt_gap);
  }
  c.stereo = rig;
  return c;
}

}  // namespace internal
}  // namespace dypho::stereo
