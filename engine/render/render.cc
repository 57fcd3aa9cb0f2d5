#include "engine/render/render.h"

#include "common/check.h"

namespace dypho {

kernels::RasterCamera ToRasterCamera(const Camera& camera, const Rigid3d& cam_from_world) {
  camera.Validate("render camera");
  kernels::RasterCamera c;
  c.fx = camera.fx;
  c.fy = camera.fy;
  c.cx = camera.cx;
  c.cy = camera.cy;
  c.width = camera.width;
  c.height = camera.height;
  const Eigen::Matrix<double, 3, 4> m = cam_from_world.ToMatrix();
  for (int i = 0; i < 12; ++i) c.cam_from_world[i] = m(i / 4, i % 4);
  return c;
}

RenderedView RenderView(const GaussianCloud& cloud, const Camera& camera, const Rigid3d& cam_from_world,
                        const kernels::RasterSettings& settings, kernels::Rasterizer* rasterizer) {
  cloud.Validate("render");
  std::unique_ptr<kernels::Rasterizer> own;
  if (rasterizer == nullptr) {
    own = kernels::CreateRasterizer(kernels::Backend::kCpu);
    rasterizer = own.get();
  }
  DYPHO_CHECK_INPUT(rasterizer->backend() == kernels::Backend::kCpu)
      << "RenderView takes host memory: use the CPU backend";
  RenderedView view;
  view.color = ImageF(camera.width, camera.height, 3);
  view.depth = ImageF(camera.width, camera.height, 1);
  view.alpha = ImageF(camera.width, camera.height, 1);
  kernels::RasterOutputs out;
  out.color = view.color.data();
  out.depth = view.depth.data();
  out.alpha = view.alpha.data();
  auto state = rasterizer->Forward(cloud.params(), ToRasterCamera(camera, cam_from_world), settings, out);
  view.stats = state->stats();
  return view;
}

ImageF NormalizedDepth(const RenderedView& view, float min_alpha) {
  ImageF d(view.depth.width(), view.depth.height(), 1);
  for (size_t i = 0; i < d.size(); ++i) {
    const float a = view.alpha.data()[i];
    d.data()[i] = a > min_alpha ? view.depth.data()[i] / a : 0.0f;
  }
  return d;
}

}  // namespace dypho
