// The CPU rasterizer under cameras no calibration would give (issue 16): a
// principal point far outside the image, focal lengths near 0 or huge,
// Gaussians touching the near plane. Whatever the camera, it must index only
// inside its buffers (the ASan build of this test proves it) and its outputs
// must stay finite.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "kernels/cpu/cpu_rasterizer.h"
#include "kernels/rasterizer.h"
#include "tests/raster_scene.h"

namespace dypho {
namespace {

using kernels::CompositeMode;
using kernels::RasterCamera;
using kernels::RasterSettings;
using testing::Grads;
using testing::MakeCamera;
using testing::RandomScene;
using testing::Render;
using testing::Scene;

struct Intrinsics {
  double fx, fy, cx, cy;
};

void RenderWithCamera(const Scene<float> &s, const RasterCamera &cam, CompositeMode mode) {
  RasterSettings set;
  set.mode = mode;
  set.num_threads = 2;
  Render<float> out(cam.width, cam.height, s.n);
  auto st = kernels::cpu::Forward<float>(s.params(), cam, set, out.outputs());
  for (float v : out.color) ASSERT_TRUE(std::isfinite(v));
  for (float v : out.alpha) ASSERT_TRUE(v >= 0 && v <= 1);
  std::vector<float> vc(out.color.size(), 0.5f), vd(out.depth.size(), 0.1f), va(out.alpha.size(), 0.2f);
  Grads<float> g(s);
  kernels::cpu::Backward<float>(*st, s.params(), cam, set, {vc.data(), vd.data(), va.data()}, g.grads());
}

TEST(HostileRaster, ExtremeIntrinsicsStayInsideTheBuffers) {
  // Near and far, small and large Gaussians, some right at the near plane.
  Scene<float> s = RandomScene<float>(400, 4, 7, 0.011, 8.0, 0.001, 3.0);
  const std::vector<Intrinsics> cameras = {
      {140, 140, 1e9, 60},    {140, 140, -1e9, 60}, {140, 140, 1e8, 60},  {140, 140, 80, 1e9},
      {140, 140, 80, -1e8},   {1e-6, 1e-6, 80, 60}, {1e12, 1e12, 80, 60}, {1e-3, 1e9, 1e9, -1e9},
      {140, 140, 1e30, 1e30}, {1e30, 1e30, 80, 60}, {140, 1e-30, 80, 60}, {3e38, 3e38, -3e38, 3e38},
  };
  for (const Intrinsics &k : cameras) {
    RasterCamera cam = MakeCamera(161, 119, 140);
    cam.fx = k.fx;
    cam.fy = k.fy;
    cam.cx = k.cx;
    cam.cy = k.cy;
    for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
      SCOPED_TRACE(::testing::Message() << "fx " << k.fx << " fy " << k.fy << " cx " << k.cx << " cy " << k.cy
                                        << " mode " << static_cast<int>(mode));
      RenderWithCamera(s, cam, mode);
    }
  }
}

TEST(HostileRaster, GaussiansLargerThanTheImageStayInsideTheBuffers) {
  Scene<float> s;
  s.sh_coeffs = 1;
  const std::vector<float> coeffs = {0.5f, 0.2f, 0.1f};
  for (float log_scale : {-20.0f, 0.0f, 10.0f, 30.0f, 80.0f}) {
    for (float z : {0.0101f, 0.02f, 1.0f, 1e6f}) {
      for (float x : {-1e6f, 0.0f, 3e4f}) {
        const float mean[3] = {x, 0.1f, z}, ls[3] = {log_scale, log_scale - 5, log_scale}, q[4] = {1, 0.2f, 0, 0};
        s.Add(mean, ls, q, 3.0f, coeffs);
      }
    }
  }
  for (CompositeMode mode : {CompositeMode::kSorted, CompositeMode::kOrderIndependent}) {
    RenderWithCamera(s, MakeCamera(64, 48, 50), mode);
    RenderWithCamera(s, MakeCamera(1, 1, 50), mode);
  }
}

}  // namespace
}  // namespace dypho
