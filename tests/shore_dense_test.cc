// The static dense map (engine/dense) on the synthetic harbour: with the
// generator's dynamic masks (pedestrians and the boat) pushed, dense.ply has
// no point off the static shore (none on the water, in the sky, or along
// the pedestrians' and the boat's paths); without them it does.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "engine/api.h"
#include "engine/export/knn.h"
#include "engine/synth/shore/shore_scene.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

ShoreSynthOptions Harbour() {
  ShoreSynthOptions o;
  o.width = 160;
  o.height = 120;
  o.frames = 90;  // the boat is in view from about frame 45
  o.num_pedestrians = 3;
  return o;
}

constexpr int kFirst = 40, kStep = 2;

std::vector<float> ReadXyz(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  EXPECT_TRUE(in.good()) << path;
  std::string line;
  int n = -1;
  while (std::getline(in, line) && line != "end_header")
    if (line.rfind("element vertex ", 0) == 0) n = std::stoi(line.substr(15));
  std::vector<float> xyz;
  std::vector<char> row(27);  // x y z nx ny nz (float) red green blue (uchar)
  for (int i = 0; i < n && in.read(row.data(), 27); ++i) {
    float f[3];
    std::memcpy(f, row.data(), 12);
    xyz.insert(xyz.end(), f, f + 3);
  }
  EXPECT_EQ(static_cast<int>(xyz.size() / 3), n);
  return xyz;
}

struct Mapped {
  std::vector<float> xyz;
  std::vector<Rigid3d> world_from_keyframe;
  double ms_per_keyframe = 0;
};

Mapped MapHarbour(const ShoreScene& scene, bool masks, const std::string& path) {
  EngineOptions o;
  o.camera = scene.camera();
  o.mapper.train_downscale = 2;
  o.mapper.sh_degree = 0;
  o.mapper.num_threads = 2;
  o.mapper.densify_every = 0;
  o.mapper.max_depth = 30;
  o.keyframes.max_frame_gap = 3;
  o.keyframes.sharpness_window = 1;
  o.keyframes.min_new_content = 0;
  o.iterations_per_keyframe = 1;
  o.final_iterations = 0;
  o.carve_votes = 0;
  o.synchronous = true;
  o.track_when_no_pose = false;
  o.dense.points.max_depth = 30;
  o.dense.map.voxel_size = 0.1;
  std::unique_ptr<Engine> engine = Engine::Create(o);
  Mapped m;
  for (int i = kFirst; i < scene.num_frames(); i += kStep) {
    const ShoreFrame f = scene.Render(i);
    FrameBuffers b;
    b.timestamp = f.timestamp;
    b.rgb = f.rgb.data();
    b.depth_m = f.depth.data();
    if (masks) b.dynamic_mask = f.dynamic.data();
    const Rigid3d pose = f.world_from_cam.Inverse();
    if (engine->PushFrame(b, &pose).keyframe) m.world_from_keyframe.push_back(f.world_from_cam);
  }
  engine->Finish();
  engine->SaveDenseCloud(path);
  m.xyz = ReadXyz(path);
  m.ms_per_keyframe = engine->DenseStatus().mean_ms();
  return m;
}

// Points farther than 0.15 m (1.5 voxels) from the static shore seen from
// the keyframes (rendered at 2x, no pedestrians, no boat), and how many of
// them lie near the water plane (z < 0.2 m) or above every static box.
int OffStatic(const ShoreScene& scene, const Mapped& m) {
  Camera cam = scene.camera();
  cam.fx *= 2;
  cam.fy *= 2;
  cam.cx = (cam.cx + 0.5) * 2 - 0.5;
  cam.cy = (cam.cy + 0.5) * 2 - 0.5;
  cam.width *= 2;
  cam.height *= 2;
  std::vector<float> surface;
  for (const Rigid3d& w : m.world_from_keyframe) {
    const SynthStaticView view = scene.RenderStatic(w, cam, 0.0);
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        const float d = view.depth.at(x, y);
        if (!(d > 0)) continue;
        const Eigen::Vector3d p = w * Eigen::Vector3d((x - cam.cx) / cam.fx * d, (y - cam.cy) / cam.fy * d, d);
        for (int a = 0; a < 3; ++a) surface.push_back(static_cast<float>(p[a]));
      }
  }
  const int n = static_cast<int>(m.xyz.size() / 3);
  const std::vector<double> d = NearestDistances(surface.data(), static_cast<int>(surface.size() / 3), m.xyz.data(), n);
  return static_cast<int>(std::count_if(d.begin(), d.end(), [](double v) { return v > 0.15; }));
}

TEST(ShoreDense, DenseMapHoldsOnlyTheStaticShoreWhenMovingThingsAreMasked) {
  const ShoreScene scene(Harbour());
  const std::string dir = testing::TestTempDir();
  const Mapped clean = MapHarbour(scene, true, dir + "/masked.ply");
  const Mapped dirty = MapHarbour(scene, false, dir + "/unmasked.ply");
  const int off_clean = OffStatic(scene, clean), off_dirty = OffStatic(scene, dirty);
  int on_water = 0;
  for (size_t i = 2; i < clean.xyz.size(); i += 3) on_water += clean.xyz[i] < 0.02f;  // the water is z = 0
  std::printf("dense harbour: %zu keyframes, %zu points masked (%d off the static shore, %d at the water line), "
              "%zu unmasked (%d off); %.2f ms per keyframe\n",
              clean.world_from_keyframe.size(), clean.xyz.size() / 3, off_clean, on_water, dirty.xyz.size() / 3,
              off_dirty, clean.ms_per_keyframe);
  EXPECT_GT(clean.xyz.size() / 3, 2000u);
  EXPECT_EQ(off_clean, 0);
  EXPECT_GT(off_dirty, 50);
}

}  // namespace
}  // namespace dypho
