// Renders the built-in demo scene through the installed dypho package and
// prints the mean colour; exits non-zero when nothing was drawn.
#include <cstdio>

#include "engine/render/demo_scene.h"
#include "engine/render/render.h"

int main() {
  const dypho::GaussianCloud cloud = dypho::MakeDemoScene();
  dypho::kernels::RasterSettings settings;
  const dypho::RenderedView view =
      dypho::RenderView(cloud, dypho::DemoCamera(160, 120), dypho::DemoCamFromWorld(), settings);
  double sum = 0;
  for (float a : view.alpha.pixels()) sum += a;
  const double coverage = sum / view.alpha.size();
  std::printf("rendered %d Gaussians, %d visible, coverage %.3f\n", cloud.size(), view.stats.num_visible, coverage);
  return coverage > 0.2 ? 0 : 1;
}
