#include "engine/render/offline_render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include <Eigen/Geometry>

#include "common/check.h"
#include "common/files.h"
#include "common/progress.h"
#include "engine/dataset/camera_file.h"
#include "engine/io/image_io.h"

namespace dypho {

ViewRenderFn CpuViewRenderer(const GaussianCloud& cloud) {
  std::shared_ptr<kernels::Rasterizer> rasterizer = kernels::CreateRasterizer(kernels::Backend::kCpu);
  return [&cloud, rasterizer](const Camera& camera, const Rigid3d& cam_from_world,
                              const kernels::RasterSettings& settings) {
    return RenderView(cloud, camera, cam_from_world, settings, rasterizer.get());
  };
}

Camera ParseIntrinsics(const std::string& text) {
  DYPHO_CHECK_INPUT(!text.empty()) << "intrinsics: empty (give a camera file or \"fx,fy,cx,cy,width,height\")";
  if (std::filesystem::exists(text)) return ReadCameraFile(text).camera;
  std::vector<double> v;
  std::stringstream s(text);
  std::string item;
  while (std::getline(s, item, ',')) {
    size_t used = 0;
    double x = 0;
    try {
      x = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    DYPHO_CHECK_INPUT(used > 0 && item.find_first_not_of(" \t", used) == std::string::npos)
        << "intrinsics \"" << text << "\": not a file and \"" << item << "\" is not a number "
        << "(expected a camera file or \"fx,fy,cx,cy,width,height\")";
    v.push_back(x);
  }
  DYPHO_CHECK_INPUT(v.size() == 6) << "intrinsics \"" << text << "\": expected 6 values fx,fy,cx,cy,width,height (got "
                                   << v.size() << ")";
  DYPHO_CHECK_INPUT(v[4] == std::floor(v[4]) && v[5] == std::floor(v[5]) && v[4] >= 1 && v[5] >= 1 && v[4] <= 32768 &&
                    v[5] <= 32768)
      << "intrinsics \"" << text << "\": width and height must be whole numbers in [1, 32768]";
  Camera c;
  c.fx = v[0];
  c.fy = v[1];
  c.cx = v[2];
  c.cy = v[3];
  c.width = static_cast<int>(v[4]);
  c.height = static_cast<int>(v[5]);
  c.Validate("intrinsics \"" + text + "\"");
  return c;
}

Rigid3d LookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target, const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (target - position).normalized();
  Eigen::Vector3d x = (-up).cross(z);
  if (x.norm() < 1e-9) x = z.unitOrthogonal();  // looking straight along up
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return Rigid3d(Eigen::Quaterniond(R), position);  // world_from_cam
}

Eigen::Vector3d MapCentre(const GaussianCloud& cloud) {
  cloud.Validate("orbit map");
  std::vector<double> axis[3];
  for (int i = 0; i < cloud.size(); ++i) {
    const float* m = &cloud.means[3 * i];
    if (!(std::isfinite(m[0]) && std::isfinite(m[1]) && std::isfinite(m[2]))) continue;
    for (int k = 0; k < 3; ++k) axis[k].push_back(m[k]);
  }
  DYPHO_CHECK_INPUT(!axis[0].empty()) << "orbit: the map has no Gaussian with a finite mean to orbit around";
  Eigen::Vector3d centre;
  for (int k = 0; k < 3; ++k) {
    auto mid = axis[k].begin() + axis[k].size() / 2;
    std::nth_element(axis[k].begin(), mid, axis[k].end());
    centre[k] = *mid;
  }
  return centre;
}

double AutoOrbitRadius(const GaussianCloud& cloud, const Eigen::Vector3d& centre) {
  std::vector<double> dist;
  for (int i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d m(cloud.means[3 * i], cloud.means[3 * i + 1], cloud.means[3 * i + 2]);
    if (m.allFinite()) dist.push_back((m - centre).norm());
  }
  if (dist.empty()) return 0.1;
  auto p80 = dist.begin() + (dist.size() * 8) / 10;
  std::nth_element(dist.begin(), p80, dist.end());
  return std::max(0.1, 2.0 * *p80);
}

Rigid3d OrbitPose(const Eigen::Vector3d& centre, double radius, double theta, double elevation,
                  const Eigen::Vector3d& up_in) {
  const Eigen::Vector3d up = up_in.normalized();
  const Eigen::Vector3d a = up.unitOrthogonal();
  const Eigen::Vector3d b = up.cross(a);
  const Eigen::Vector3d dir =
      std::cos(elevation) * (std::cos(theta) * a + std::sin(theta) * b) + std::sin(elevation) * up;
  return LookAt(centre + radius * dir, centre, up);
}

Trajectory OrbitPath(const GaussianCloud& cloud, const OrbitOptions& options) {
  DYPHO_CHECK_INPUT(options.frames >= 1) << "orbit frames must be >= 1 (got " << options.frames << ")";
  DYPHO_CHECK_INPUT(std::isfinite(options.radius) && options.radius >= 0)
      << "orbit radius must be >= 0 (got " << options.radius << ")";
  DYPHO_CHECK_INPUT(options.up.allFinite() && options.up.norm() > 1e-9) << "orbit up vector must be non-zero";
  DYPHO_CHECK_INPUT(std::isfinite(options.elevation) && std::isfinite(options.revolutions))
      << "orbit elevation and revolutions must be finite";
  const Eigen::Vector3d centre = MapCentre(cloud);
  const double radius = options.radius == 0.0 ? AutoOrbitRadius(cloud, centre) : options.radius;
  Trajectory path;
  for (int f = 0; f < options.frames; ++f) {
    const double theta = 2.0 * M_PI * options.revolutions * f / options.frames;
    path.Add(f * options.timestep, OrbitPose(centre, radius, theta, options.elevation, options.up));
  }
  return path;
}

OfflineRenderSummary RenderPath(const Camera& camera, const Trajectory& path, const std::string& out_dir,
                                const OfflineRenderOptions& options, const ViewRenderFn& render) {
  DYPHO_CHECK_INPUT(!path.empty()) << "render: the camera path has no poses";
  DYPHO_CHECK_INPUT(std::isfinite(options.depth_factor) && options.depth_factor > 0)
      << "render: depth_factor must be > 0 (got " << options.depth_factor << ")";
  camera.Validate("render intrinsics");
  std::string error;
  DYPHO_CHECK_INPUT(options.settings.IsValid(&error)) << "render settings: " << error;
  DYPHO_CHECK(static_cast<bool>(render)) << "RenderPath without a renderer";
  MakeOutputDirectory(out_dir);
  const auto t0 = std::chrono::steady_clock::now();
  Progress progress("render", static_cast<long>(path.size()));
  char name[64];
  for (size_t f = 0; f < path.size(); ++f) {
    const RenderedView view = render(camera, path.world_from_cam[f].Inverse(), options.settings);
    std::snprintf(name, sizeof(name), "color_%06zu.png", f);
    WriteRgb8(JoinPath(out_dir, name), ToRgb8(view.color));
    std::snprintf(name, sizeof(name), "depth_%06zu.png", f);
    WriteDepth16(JoinPath(out_dir, name), DepthToU16(NormalizedDepth(view, options.min_alpha), options.depth_factor));
    progress.Advance(1);
  }
  progress.Finish();
  WriteTumTrajectory(JoinPath(out_dir, "poses.txt"), path);
  OfflineRenderSummary summary;
  summary.frames = static_cast<int>(path.size());
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

}  // namespace dypho
