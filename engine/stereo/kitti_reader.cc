// The KITTI odometry layout (see stereo_dataset.h).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <map>
#include <memory>
#include <sstream>

#include "common/check.h"
#include "engine/stereo/stereo_dataset.h"

namespace dypho::stereo {
namespace fs = std::filesystem;
namespace {

// Whitespace-separated finite numbers of one line; throws naming file:line.
std::vector<double> Numbers(const std::string& text, const std::string& where) {
  std::istringstream in(text);
  std::vector<double> values;
  std::string token;
  while (in >> token) {
    char* end = nullptr;
    const double v = std::strtod(token.c_str(), &end);
    DYPHO_CHECK_INPUT(end != token.c_str() && *end == '\0') << where << ": '" << token << "' is not a number";
    DYPHO_CHECK_INPUT(std::isfinite(v)) << where << ": non-finite number '" << token << "'";
    values.push_back(v);
  }
  return values;
}

std::vector<std::string> Images(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string ext = e.path().extension().string();
    if (e.is_regular_file() && (ext == ".png" || ext == ".jpg" || ext == ".pgm" || ext == ".ppm"))
      names.push_back(e.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

std::vector<double> ReadKittiTimes(const std::string& path) {
  std::ifstream in(path);
  DYPHO_CHECK_INPUT(in.good()) << path << ": cannot be read";
  std::vector<double> times;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const std::vector<double> v = Numbers(line, path + ":" + std::to_string(n));
    if (v.empty()) continue;
    DYPHO_CHECK_INPUT(v.size() == 1) << path << ":" << n << ": one time a line expected";
    DYPHO_CHECK_INPUT(times.empty() || v[0] > times.back()) << path << ":" << n << ": times must increase";
    times.push_back(v[0]);
  }
  return times;
}

Trajectory ReadKittiPoses(const std::string& path, const std::vector<double>& times) {
  std::ifstream in(path);
  DYPHO_CHECK_INPUT(in.good()) << path << ": cannot be read";
  Trajectory t;
  std::string line;
  int n = 0;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    const std::vector<double> v = Numbers(line, path + ":" + std::to_string(line_no));
    if (v.empty()) continue;
    DYPHO_CHECK_INPUT(v.size() == 12) << path << ":" << line_no << ": 12 numbers expected, found " << v.size();
    DYPHO_CHECK_INPUT(size_t(n) < times.size())
        << path << ":" << line_no << ": more poses than frames (" << times.size() << ")";
    Eigen::Matrix<double, 3, 4> m;
    for (int k = 0; k < 12; ++k) m(k / 4, k % 4) = v[k];
    const Eigen::Matrix3d r = m.leftCols<3>();
    DYPHO_CHECK_INPUT((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-3)
        << path << ":" << line_no << ": the rotation is not orthonormal";
    t.Add(times[n++], Rigid3d::FromMatrix(m));
  }
  DYPHO_CHECK_INPUT(size_t(n) == times.size())
      << path << ": " << n << " poses for " << times.size() << " frames";
  return t;
}

namespace internal {

std::optional<Dataset::Contents> OpenKitti(const std::string& folder) {
  const fs::path root(folder), calib = root / "calib.txt";
  const bool grey = fs::is_directory(root / "image_0"), colour = fs::is_directory(root / "image_2");
  if (!fs::exists(calib) || (!grey && !colour)) return std::nullopt;
  const std::string left_dir = grey ? "image_0" : "image_2", right_dir = grey ? "image_1" : "image_3";
  const std::string left_key = grey ? "P0" : "P2", right_key = grey ? "P1" : "P3";
  DYPHO_CHECK_INPUT(fs::is_directory(root / right_dir))
      << (root / right_dir).string() << ": missing (the right images of " << left_dir << "/)";
  // calib.txt: "Pn: 12 numbers".
  std::map<std::string, std::pair<std::vector<double>, int>> matrices;
  {
    std::ifstream in(calib);
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
      const size_t colon = line.find(':');
      if (colon == std::string::npos) continue;
      const std::string key = line.substr(0, colon);
      const std::string where = calib.string() + ":" + std::to_string(n);
      std::vector<double> v = Numbers(line.substr(colon + 1), where);
      if (key == left_key || key == right_key)
        DYPHO_CHECK_INPUT(v.size() == 12) << where << ": " << key << " needs 12 numbers, found " << v.size();
      matrices[key] = {std::move(v), n};
    }
  }
  for (const std::string& key : {left_key, right_key})
    DYPHO_CHECK_INPUT(matrices.count(key)) << calib.string() << ": no " << key << " line";
  const std::vector<double>& p_left = matrices[left_key].first;
  const std::vector<double>& p_right = matrices[right_key].first;
  const std::string right_where = calib.string() + ":" + std::to_string(matrices[right_key].second);
  DYPHO_CHECK_INPUT(p_left[0] > 0 && p_right[0] > 0) << right_where << ": focal length must be > 0";
  // Baseline of the right camera relative to the left one (P = K [I | t]).
  const double tx_left = p_left[3] / p_left[0], tx_right = p_right[3] / p_right[0];
  const double baseline = tx_left - tx_right;
  DYPHO_CHECK_INPUT(std::abs(baseline) > 1e-6) << right_where << ": zero baseline (" << right_key << " and "
                                               << left_key << " have the same translation)";

  const std::vector<std::string> names = Images(root / left_dir);
  DYPHO_CHECK_INPUT(!names.empty()) << (root / left_dir).string() << ": no images";
  Dataset::Contents c;
  c.folder = folder;
  c.name = fs::absolute(root).lexically_normal().filename().string();
  if (c.name.empty()) c.name = fs::absolute(root).lexically_normal().parent_path().filename().string();
  c.format = "kitti";
  std::vector<double> times;
  const fs::path times_path = root / "times.txt";
  if (fs::exists(times_path)) {
    times = ReadKittiTimes(times_path.string());
    DYPHO_CHECK_INPUT(times.size() == names.size())
        << times_path.string() << ": " << times.size() << " times for " << names.size() << " images in "
        << left_dir << "/";
  } else {
    for (size_t i = 0; i < names.size(); ++i) times.push_back(0.1 * i);
  }
  for (size_t i = 0; i < names.size(); ++i) {
    FrameInfo f;
    f.index = i;
    f.timestamp = times[i];
    f.rgb_path = (root / left_dir / names[i]).string();
    f.right_path = (root / right_dir / names[i]).string();
    f.rgb_source = left_dir + "/" + names[i];
    f.has_depth = true;
    c.frames.push_back(f);
  }
  CheckPairsExist(c);
  const fs::path poses = root / "poses.txt";
  if (fs::exists(poses)) {
    c.ground_truth = ReadKittiPoses(poses.string(), times);
    c.ground_truth_path = poses.string();
    for (size_t i = 0; i < c.frames.size(); ++i) c.frames[i].world_from_cam_gt = c.ground_truth.world_from_cam[i];
  }
  // Camera: from the left projection matrix; size from the first image.
  StereoCalibration s;
  s.source = calib.string();
  s.left.fx = p_left[0], s.left.fy = p_left[5], s.left.cx = p_left[2], s.left.cy = p_left[6];
  const cv::Size size = ImageSize(c.frames.front().rgb_path);
  s.left.width = size.width, s.left.height = size.height;
  s.right = s.left;
  s.right_from_left_translation = Eigen::Vector3d(-baseline, 0, 0);
  auto rig = std::make_shared<StereoRig>(MakeRig(s));
  c.camera = rig->camera;
  c.camera_source = calib.string() + " (" + left_key + ", baseline " + std::to_string(rig->baseline) + " m)";
  c.stereo = rig;
  return c;
}

}  // namespace internal
}  // namespace dypho::stereo
