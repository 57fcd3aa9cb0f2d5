// The synthetic generator's renderer and scene (engine/synth): exact depth
// of walls, tilted planes and box corners, no gaps between faces, depth on
// scene surfaces, masks exactly where walkers are, walker motion.
#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/synth/camera_motion.h"
#include "engine/synth/quad_renderer.h"
#include "engine/synth/scene_layout.h"
#include "engine/synth/synthetic_scene.h"
#include "tests/synth_test_options.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

using Eigen::Vector3d;
using synth_testing::Coverage;
using synth_testing::kDeg;
using synth_testing::SmallOptions;

// |signed distance| from world point p to the surface of a box.
double BoxSurfaceDistance(const Rigid3d& world_from_box, const Vector3d& size, const Vector3d& p) {
  const Vector3d q = (world_from_box.Inverse() * p).cwiseAbs() - 0.5 * size;
  const double outside = q.cwiseMax(0.0).norm();
  const double inside = std::min(q.maxCoeff(), 0.0);
  return std::abs(outside + inside);
}

// ---------------------------------------------------------------------------
// Renderer: exact geometry

// A camera at the world origin looking along +z (world = camera frame).
Camera TestCamera() { return SmallOptions().MakeCamera(); }

synth::Quad WallFacingCamera(double z) {
  // A 20 x 20 m wall in the plane z = const, visible from the origin.
  synth::Quad q = synth::MakeQuad(Vector3d(0, 0, z), -Vector3d::UnitZ(), -Vector3d::UnitY(), 20.0, 20.0);
  return q;
}

TEST(QuadRendererTest, FrontoParallelWallHasExactDepth) {
  const Camera camera = TestCamera();
  for (double distance : {0.5, 1.25, 3.0, 7.75}) {
    const synth::QuadRender r =
        synth::RenderQuads({WallFacingCamera(distance)}, {}, Rigid3d(), camera, /*with_colour=*/false);
    for (int y = 0; y < camera.height; ++y) {
      for (int x = 0; x < camera.width; ++x) {
        ASSERT_EQ(r.depth.at(x, y), static_cast<float>(distance)) << x << "," << y;
        ASSERT_EQ(r.mask.at(x, y), 0);
      }
    }
  }
}

TEST(QuadRendererTest, TiltedCameraDepthMatchesPlaneEquation) {
  // Plane y = 3 (world), seen from a rotated camera: camera z of the hit point
  // through pixel (u, v) is d / (n_cam . ray).
  const Camera camera = TestCamera();
  synth::Quad wall = synth::MakeQuad(Vector3d(0, 3, 1), -Vector3d::UnitY(), Vector3d::UnitZ(), 40.0, 40.0);
  const Rigid3d world_from_cam = synth::LookAt(Vector3d(0.3, 0.5, 1.2), Vector3d(1.1, 3.0, 0.7));
  const Rigid3d cam_from_world = world_from_cam.Inverse();
  const synth::QuadRender r = synth::RenderQuads({wall}, {}, cam_from_world, camera, false);
  const Vector3d n_cam = cam_from_world.rotation * wall.normal;
  const double h = n_cam.dot(cam_from_world * wall.origin);
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const Vector3d ray((x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy, 1.0);
      const double expected = h / n_cam.dot(ray);
      ASSERT_NEAR(r.depth.at(x, y), expected, 1e-6 * expected) << x << "," << y;
      // The unprojected point lies on the plane.
      const Vector3d p = world_from_cam * camera.Unproject(Eigen::Vector2d(x, y), r.depth.at(x, y));
      ASSERT_NEAR(p.y(), 3.0, 1e-5);
    }
  }
}

// Reference: nearest hit of the ray t * dir (t = camera z since dir.z = 1)
// with an axis-aligned box by the slab method.
double SlabHit(const Vector3d& dir, const Vector3d& lo, const Vector3d& hi) {
  double t0 = 0.0, t1 = 1e30;
  for (int i = 0; i < 3; ++i) {
    if (dir[i] == 0.0) {
      if (0.0 < lo[i] || 0.0 > hi[i]) return -1.0;
      continue;
    }
    double a = lo[i] / dir[i], b = hi[i] / dir[i];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return t0 <= t1 ? t0 : -1.0;
}

TEST(QuadRendererTest, BoxCornerProjectsToTheRightPixelAndMatchesSlabReference) {
  const Camera camera = TestCamera();
  // A 0.5 m cube whose front face lies in z = 2, in front of a wall at z = 4.
  const Vector3d lo(0.05, -0.05, 2.0), hi(0.55, 0.45, 2.5);
  std::vector<synth::Quad> quads = {WallFacingCamera(4.0)};
  for (synth::Quad q : synth::BoxQuads(Rigid3d(Eigen::Quaterniond::Identity(), 0.5 * (lo + hi)), hi - lo)) {
    q.object = 0;  // count it as a walker so the mask shows it
    quads.push_back(q);
  }
  const synth::QuadRender r = synth::RenderQuads(quads, {}, Rigid3d(), camera, false);

  // The front face's top-left corner projects to (82.78125, 56.21875): pixel
  // (83, 57) is the first inside, (82, 57) and (83, 56) see the wall.
  const Eigen::Vector2d corner = camera.Project(lo);
  EXPECT_DOUBLE_EQ(corner.x(), 82.78125);
  EXPECT_DOUBLE_EQ(corner.y(), 56.21875);
  EXPECT_EQ(r.depth.at(83, 57), 2.0f);
  EXPECT_EQ(r.mask.at(83, 57), 255);
  EXPECT_EQ(r.depth.at(82, 57), 4.0f);
  EXPECT_EQ(r.mask.at(82, 57), 0);
  EXPECT_EQ(r.depth.at(83, 56), 4.0f);
  // The bottom-right corner (0.55, 0.45, 2) projects to (115.59375, 89.03125).
  EXPECT_EQ(r.depth.at(115, 89), 2.0f);
  EXPECT_EQ(r.depth.at(116, 89), 4.0f);

  // Every pixel against an independent ray-box reference.
  int box_pixels = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const Vector3d dir((x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy, 1.0);
      const double t_box = SlabHit(dir, lo, hi);
      const double expected = t_box > 0.0 ? t_box : 4.0;
      ASSERT_NEAR(r.depth.at(x, y), expected, 1e-6) << x << "," << y;
      ASSERT_EQ(r.mask.at(x, y), t_box > 0.0 ? 255 : 0) << x << "," << y;
      box_pixels += t_box > 0.0;
    }
  }
  EXPECT_GT(box_pixels, 900);  // front face about 33 x 33 px plus the visible side
}

TEST(QuadRendererTest, AdjacentFacesLeaveNoGaps) {
  // A rotated box in front of nothing: every pixel inside its silhouette must
  // hit it (a gap would show depth 0).
  const Camera camera = TestCamera();
  const Rigid3d world_from_box(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Vector3d(1, 2, 3).normalized())),
                               Vector3d(0.1, -0.05, 2.0));
  std::vector<synth::Quad> quads;
  for (const synth::Quad& q : synth::BoxQuads(world_from_box, Vector3d(0.8, 0.6, 0.7))) quads.push_back(q);
  const synth::QuadRender r = synth::RenderQuads(quads, {}, Rigid3d(), camera, false);
  // Reference silhouette: ray-box test in the box frame.
  const Rigid3d box_from_cam = world_from_box.Inverse();
  int hits = 0;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const Vector3d dir((x - camera.cx) / camera.fx, (y - camera.cy) / camera.fy, 1.0);
      const Vector3d o = box_from_cam.translation, d = box_from_cam.rotation * dir;
      double t0 = 0.0, t1 = 1e30;
      for (int i = 0; i < 3; ++i) {
        const double half = 0.5 * Vector3d(0.8, 0.6, 0.7)[i];
        double a = (-half - o[i]) / d[i], b = (half - o[i]) / d[i];
        if (a > b) std::swap(a, b);
        t0 = std::max(t0, a);
        t1 = std::min(t1, b);
      }
      const bool hit = t0 <= t1;
      if (hit) {
        ++hits;
        ASSERT_NEAR(r.depth.at(x, y), t0, 1e-5 * t0) << x << "," << y;
      } else {
        ASSERT_EQ(r.depth.at(x, y), 0.0f) << x << "," << y;
      }
    }
  }
  EXPECT_GT(hits, 1000);
}

// ---------------------------------------------------------------------------
// Scene

TEST(SynthSceneTest, CameraFacingTheBackWallSeesItsExactDistance) {
  const SyntheticScene scene(SmallOptions(3, 1));
  // The back wall is the plane y = -2.5; a camera at y = -1.5 looking at it.
  const Rigid3d pose = synth::LookAt(Vector3d(0.0, -1.5, 1.35), Vector3d(0.0, -3.0, 1.35));
  const SynthStaticView view = scene.RenderStatic(pose, scene.camera());
  for (int y = 0; y < view.depth.height(); ++y) {
    for (int x = 0; x < view.depth.width(); ++x) ASSERT_EQ(view.depth.at(x, y), 1.0f) << x << "," << y;
  }
  EXPECT_EQ(view.rgb.width(), 160);
  EXPECT_EQ(scene.room().min().y(), -2.5);
}

TEST(SynthSceneTest, EveryDepthPixelLiesOnASceneSurface) {
  const SyntheticScene scene(SmallOptions(5, 3, SynthMotion::kHalfsphere, 20));
  const Camera& camera = scene.camera();
  std::vector<SynthBox> statics = scene.static_boxes();
  const Eigen::AlignedBox3d room = scene.room();
  statics.push_back({Rigid3d(Eigen::Quaterniond::Identity(), room.center()), room.sizes(), -1});
  for (int i : {0, 10, 19}) {
    const SynthFrame frame = scene.Render(i);
    const std::vector<SynthBox> walkers = scene.walker_boxes(i);
    ASSERT_EQ(walkers.size(), 3u * 13u);
    for (int y = 0; y < camera.height; ++y) {
      for (int x = 0; x < camera.width; ++x) {
        const float z = frame.depth.at(x, y);
        ASSERT_GT(z, 0.0f);
        const Vector3d p = frame.world_from_cam * camera.Unproject(Eigen::Vector2d(x, y), z);
        const std::vector<SynthBox>& boxes = frame.mask.at(x, y) ? walkers : statics;
        double nearest = 1e9;
        for (const SynthBox& b : boxes)
          nearest = std::min(nearest, BoxSurfaceDistance(b.world_from_box, b.size, p));
        ASSERT_LT(nearest, 2e-5) << "frame " << i << " pixel " << x << "," << y << " mask "
                                 << int(frame.mask.at(x, y));
      }
    }
  }
}

TEST(SynthSceneTest, MaskIsExactlyWhereAWalkerIsInFrontOfTheStaticScene) {
  const SyntheticScene scene(SmallOptions(11, 4, SynthMotion::kRpy, 30));
  double total = 0.0;
  for (int i = 0; i < scene.num_frames(); i += 3) {
    const SynthFrame frame = scene.Render(i);
    const SynthStaticView still = scene.RenderStatic(frame.world_from_cam, scene.camera());
    for (int y = 0; y < frame.mask.height(); ++y) {
      for (int x = 0; x < frame.mask.width(); ++x) {
        const bool walker_in_front = frame.depth.at(x, y) < still.depth.at(x, y);
        ASSERT_EQ(frame.mask.at(x, y) == 255, walker_in_front) << "frame " << i << " " << x << "," << y;
        ASSERT_TRUE(frame.mask.at(x, y) == 0 || frame.mask.at(x, y) == 255);
        if (!walker_in_front) {
          // Static pixels are bit-identical to the static render.
          ASSERT_EQ(frame.depth.at(x, y), still.depth.at(x, y));
          for (int c = 0; c < 3; ++c) ASSERT_EQ(frame.rgb.at(x, y, c), still.rgb.at(x, y, c));
        }
      }
    }
    total += Coverage(frame.mask);
  }
  EXPECT_GT(total, 0.0);
}

TEST(SynthSceneTest, WalkerCoverageStaysWithinBoundsAndIsSizeable) {
  struct Case {
    uint64_t seed;
    int walkers;
    SynthMotion motion;
    double max_coverage;
  };
  for (const Case& c : {Case{1, 1, SynthMotion::kXyz, 0.4}, Case{2, 4, SynthMotion::kHalfsphere, 0.4},
                        Case{3, 2, SynthMotion::kStatic, 0.4}, Case{4, 3, SynthMotion::kRpy, 0.25}}) {
    SynthOptions o = SmallOptions(c.seed, c.walkers, c.motion, 45);
    o.max_coverage = c.max_coverage;
    o.depth_noise = false;
    const SyntheticScene scene(o);
    double max_coverage = 0.0;
    int with_walkers = 0;
    for (int i = 0; i < scene.num_frames(); i += 3) {
      const double coverage = Coverage(scene.Render(i).mask);
      max_coverage = std::max(max_coverage, coverage);
      with_walkers += coverage > 0.0;
    }
    EXPECT_LE(max_coverage, c.max_coverage) << "seed " << c.seed;
    EXPECT_GT(max_coverage, 0.08) << "seed " << c.seed << ": walkers should cover a sizeable part";
    EXPECT_GE(with_walkers, 8) << "seed " << c.seed;
  }
}

TEST(SynthSceneTest, WalkersMoveStopAndTurn) {
  // Over 12 s every walker walks (moves > 1 m) and turns (heading changes).
  SynthOptions o = SmallOptions(8, 4, SynthMotion::kStatic, 360);
  o.max_coverage = 1.0;
  const SyntheticScene scene(o);
  for (int k = 0; k < 4; ++k) {
    double travelled = 0.0, max_step = 0.0;
    std::set<int> headings;
    int still_frames = 0;
    Vector3d prev = scene.walker_boxes(0)[k * 13].world_from_box.translation;
    for (int i = 1; i < scene.num_frames(); ++i) {
      const SynthBox torso = scene.walker_boxes(i)[k * 13];
      const Vector3d p = torso.world_from_box.translation;
      const double step = (p - prev).head<2>().norm();
      travelled += step;
      max_step = std::max(max_step, step);
      still_frames += step < 1e-9;
      const Vector3d forward = torso.world_from_box.rotation * Vector3d::UnitX();
      headings.insert(static_cast<int>(std::floor(std::atan2(forward.y(), forward.x()) / (30 * kDeg))));
      prev = p;
      // Walkers stay inside the room.
      EXPECT_TRUE(scene.room().contains(p)) << "walker " << k << " frame " << i;
    }
    EXPECT_GT(travelled, 1.0) << "walker " << k;
    EXPECT_LT(max_step, 1.6 * o.walker_speed / o.fps) << "walker " << k << " jumps";
    EXPECT_GE(headings.size(), 2u) << "walker " << k << " never turns";
    EXPECT_GT(still_frames, 0) << "walker " << k << " never stops";
  }
}


}  // namespace
}  // namespace dypho
