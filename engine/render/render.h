// Rendering a GaussianCloud into images with any rasterizer backend.
#pragma once

#include <memory>

#include "common/camera.h"
#include "common/image.h"
#include "common/rigid3.h"
#include "engine/gaussians.h"
#include "kernels/rasterizer.h"

namespace dypho {

struct RenderedView {
  ImageF color;  // RGB, linear [0, 1] (not clamped)
  ImageF depth;  // expected camera z [m] (weighted by alpha)
  ImageF alpha;  // accumulated opacity
  kernels::RasterStats stats;
};

// The rasterizer camera for intrinsics and a pose. Distortion is ignored:
// renders are ideal pinhole images.
kernels::RasterCamera ToRasterCamera(const Camera& camera, const Rigid3d& cam_from_world);

// Renders `cloud` with the CPU backend (or `rasterizer` when given).
RenderedView RenderView(const GaussianCloud& cloud, const Camera& camera, const Rigid3d& cam_from_world,
                        const kernels::RasterSettings& settings, kernels::Rasterizer* rasterizer = nullptr);

// depth / alpha where alpha > min_alpha, else 0: the depth of what the pixel shows.
ImageF NormalizedDepth(const RenderedView& view, float min_alpha = 0.5f);

}  // namespace dypho
