#include "engine/synth/synthetic_scene.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"
#include "common/logging.h"
#include "engine/synth/camera_motion.h"
#include "engine/synth/depth_noise.h"
#include "engine/synth/quad_renderer.h"
#include "engine/synth/random.h"
#include "engine/synth/scene_layout.h"
#include "engine/synth/texture.h"
#include "engine/synth/walker.h"
#include "engine/synth/walker_look.h"

namespace dypho {
namespace {

using Eigen::Vector3d;
using Eigen::Vector3f;
using synth::Material;
using synth::PaintStyle;
using synth::Quad;

// Texture resolution [texels per metre] of room surfaces, furniture, walkers.
constexpr double kRoomTexels = 160.0;
constexpr double kCeilingTexels = 100.0;
constexpr double kFurnitureTexels = 200.0;
constexpr double kWalkerTexels = 300.0;

// Walker planning: the coverage check renders walker silhouettes at this
// width (the same for every output size, so paths do not depend on the
// resolution) and keeps a margin for the difference in pixel sampling.
constexpr double kPlanningWidth = 320.0;
constexpr double kCoverageMargin = 0.015;
constexpr double kWalkerClearance = 0.9;  // min distance of walker centres from the camera path [m]
constexpr double kNearStep = 0.15;        // how far the walking area moves back per attempt [m]

// Lambertian shading from a fixed light above, in front and to the right of
// the home view, plus a weak fill light from the opposite side and ambient.
float Shade(const Vector3d& normal) {
  static const Vector3d kLight = Vector3d(0.35, -0.55, 0.76).normalized();
  const double d = normal.dot(kLight);
  return static_cast<float>(0.5 + 0.5 * std::max(0.0, d) + 0.12 * std::max(0.0, -d));
}

struct TextureJob {
  PaintStyle style;
  double width_m;
  double height_m;
  double texels_per_m;
};

}  // namespace

struct SyntheticScene::Impl {
  SynthOptions options;
  Camera camera;
  Trajectory trajectory;
  std::vector<synth::Texture> textures;
  std::vector<Quad> static_quads;
  std::vector<SynthBox> static_boxes;
  std::vector<synth::WalkerBody> bodies;
  std::vector<synth::WalkerPlan> plans;
  // Texture of each face of each part of each walker.
  std::vector<std::array<std::array<int, synth::kBoxFaces>, synth::kNumWalkerParts>> walker_textures;
  synth::WalkRegion region;

  double FrameTime(int i) const { return i / options.fps; }

  void AppendWalkerQuads(double t, std::vector<Quad>* quads) const {
    for (size_t k = 0; k < plans.size(); ++k) {
      const auto poses = synth::WalkerPartPoses(bodies[k], plans[k].StateAt(t));
      for (int p = 0; p < synth::kNumWalkerParts; ++p) {
        const auto faces = synth::BoxQuads(poses[p], bodies[k].size[p]);
        for (int f = 0; f < synth::kBoxFaces; ++f) {
          Quad q = faces[f];
          q.texture = walker_textures[k][p][f];
          q.shade = Shade(q.normal);
          q.object = static_cast<int>(k);
          quads->push_back(q);
        }
      }
    }
  }

  void PlanWalkers(const SynthOptions& o) {
    plans.clear();
    const double duration = (o.frames - 1) / o.fps;
    for (int k = 0; k < o.num_walkers; ++k) {
      plans.emplace_back(k, o.seed, region, duration, o.walker_speed);
    }
  }

  // Largest fraction of the planning image covered by walker silhouettes
  // (static occluders ignored: an upper bound of the mask's coverage).
  double MaxSilhouetteCoverage(const Camera& planning_camera) const {
    double worst = 0.0;
    // One parallel loop over frames (the rasterizer's own loop then runs
    // serially inside), which keeps thread hand-offs few.
#pragma omp parallel for schedule(dynamic, 4) reduction(max : worst)
    for (int i = 0; i < options.frames; ++i) {
      std::vector<Quad> quads;
      AppendWalkerQuads(FrameTime(i), &quads);
      const synth::VisibilityBuffer vis =
          synth::RasterizeQuads(quads, trajectory.world_from_cam[i].Inverse(), planning_camera);
      const long covered = std::count_if(vis.quad.begin(), vis.quad.end(), [](int32_t q) { return q >= 0; });
      worst = std::max(worst, static_cast<double>(covered) / vis.quad.size());
    }
    return worst;
  }
};

SyntheticScene::SyntheticScene(const SynthOptions& options) : impl_(std::make_unique<Impl>()) {
  options.Validate();
  Impl& m = *impl_;
  m.options = options;
  m.camera = options.MakeCamera();
  m.camera.Validate("synthetic sequence options");
  m.trajectory = MakeSynthTrajectory(options);

  // Static geometry and the textures it needs.
  std::vector<TextureJob> jobs;
  auto add_box = [&](const Rigid3d& world_from_box, const Vector3d& size, bool inward,
                     const std::array<PaintStyle, synth::kBoxFaces>& styles,
                     const std::array<double, synth::kBoxFaces>& texels) {
    const auto faces = synth::BoxQuads(world_from_box, size, inward);
    const auto sizes = synth::BoxFaceSizes(size);
    for (int f = 0; f < synth::kBoxFaces; ++f) {
      Quad q = faces[f];
      q.texture = static_cast<int>(jobs.size());
      q.shade = Shade(q.normal);
      jobs.push_back({styles[f], sizes[f].x(), sizes[f].y(), texels[f]});
      m.static_quads.push_back(q);
    }
  };
  auto styled = [](Material m) {
    PaintStyle s;
    s.material = m;
    return s;
  };
  {
    const Vector3d lo(synth::kRoomMinX, synth::kRoomMinY, 0.0);
    const Vector3d hi(synth::kRoomMaxX, synth::kRoomMaxY, synth::kRoomHeight);
    std::array<PaintStyle, synth::kBoxFaces> styles;
    styles.fill(styled(Material::kWall));
    styles[4] = styled(Material::kCeiling);
    styles[5] = styled(Material::kFloor);
    std::array<double, synth::kBoxFaces> texels;
    texels.fill(kRoomTexels);
    texels[4] = kCeilingTexels;
    add_box(Rigid3d(Eigen::Quaterniond::Identity(), 0.5 * (lo + hi)), hi - lo, /*inward=*/true, styles,
            texels);
  }
  for (const synth::FurnitureBox& b : synth::FurnitureLayout()) {
    std::array<PaintStyle, synth::kBoxFaces> styles;
    styles.fill(styled(b.material));
    styles[4] = styles[5] = styled(b.top_material);
    std::array<double, synth::kBoxFaces> texels;
    texels.fill(kFurnitureTexels);
    add_box(b.world_from_box, b.size, false, styles, texels);
    m.static_boxes.push_back({b.world_from_box, b.size, -1});
  }

  // Walkers: looks (textures) and bodies.
  for (int k = 0; k < options.num_walkers; ++k) {
    const synth::WalkerLook look = synth::MakeWalkerLook(k, options.seed);
    m.bodies.emplace_back(look.scale);
    std::array<std::array<int, synth::kBoxFaces>, synth::kNumWalkerParts> ids;
    for (int p = 0; p < synth::kNumWalkerParts; ++p) {
      const auto sizes = synth::BoxFaceSizes(m.bodies.back().size[p]);
      for (int f = 0; f < synth::kBoxFaces; ++f) {
        ids[p][f] = static_cast<int>(jobs.size());
        jobs.push_back({look.styles[p][f], sizes[f].x(), sizes[f].y(), kWalkerTexels});
      }
    }
    m.walker_textures.push_back(ids);
  }

  // Paint every texture (independent jobs, each seeded by its index).
  m.textures.resize(jobs.size());
  const uint64_t texture_seed = synth::Hash(options.seed, 0x7e47);
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < static_cast<int>(jobs.size()); ++i) {
    const TextureJob& job = jobs[i];
    m.textures[i] = synth::PaintTexture(job.style, job.width_m, job.height_m, job.texels_per_m,
                                        synth::Hash(texture_seed, static_cast<uint64_t>(i)));
  }

  // Walker paths: start with the walking area just clear of the camera path
  // and move it back until the silhouettes stay under max_coverage.
  m.region.y_camera = synth::CameraHome().y();
  m.region.y_far = synth::kWalkYFar;
  m.region.x_max = synth::kWalkXMax;
  double camera_y = -1e9;
  for (const Rigid3d& pose : m.trajectory.world_from_cam) camera_y = std::max(camera_y, pose.translation.y());
  m.region.y_near = camera_y + kWalkerClearance;
  if (options.num_walkers == 0) return;
  const Camera planning_camera = m.camera.Scaled(kPlanningWidth / m.camera.width);
  const double limit = options.max_coverage - kCoverageMargin;
  while (true) {
    m.PlanWalkers(options);
    const double coverage = m.MaxSilhouetteCoverage(planning_camera);
    if (coverage <= limit) break;
    m.region.y_near += kNearStep;
    DYPHO_CHECK_INPUT(m.region.y_near <= m.region.y_far - 0.3)
        << "synthetic sequence options: max_coverage " << options.max_coverage << " cannot be met with "
        << options.num_walkers << " walkers (they cover " << coverage
        << " of the image even at the far end of the room); raise max_coverage or lower num_walkers";
  }
  DYPHO_LOG(Debug) << "synthetic scene: " << m.textures.size() << " textures, " << m.static_quads.size()
                   << " static quads, walkers from y = " << m.region.y_near << " m";
}

SyntheticScene::~SyntheticScene() = default;

const SynthOptions& SyntheticScene::options() const { return impl_->options; }
const Camera& SyntheticScene::camera() const { return impl_->camera; }
const Trajectory& SyntheticScene::trajectory() const { return impl_->trajectory; }
int SyntheticScene::num_frames() const { return impl_->options.frames; }
double SyntheticScene::walk_y_near() const { return impl_->region.y_near; }

Eigen::AlignedBox3d SyntheticScene::room() const {
  return Eigen::AlignedBox3d(Vector3d(synth::kRoomMinX, synth::kRoomMinY, 0.0),
                             Vector3d(synth::kRoomMaxX, synth::kRoomMaxY, synth::kRoomHeight));
}

const std::vector<SynthBox>& SyntheticScene::static_boxes() const { return impl_->static_boxes; }

std::vector<SynthBox> SyntheticScene::walker_boxes(int frame_index) const {
  DYPHO_CHECK_INPUT(frame_index >= 0 && frame_index < num_frames())
      << "frame_index " << frame_index << " is outside [0, " << num_frames() << ")";
  std::vector<SynthBox> out;
  const Impl& m = *impl_;
  for (size_t k = 0; k < m.plans.size(); ++k) {
    const auto poses = synth::WalkerPartPoses(m.bodies[k], m.plans[k].StateAt(m.FrameTime(frame_index)));
    for (int p = 0; p < synth::kNumWalkerParts; ++p) {
      out.push_back({poses[p], m.bodies[k].size[p], static_cast<int>(k)});
    }
  }
  return out;
}

SynthFrame SyntheticScene::Render(int frame_index) const {
  DYPHO_CHECK_INPUT(frame_index >= 0 && frame_index < num_frames())
      << "frame_index " << frame_index << " is outside [0, " << num_frames() << ")";
  const Impl& m = *impl_;
  SynthFrame frame;
  frame.index = frame_index;
  frame.timestamp = m.trajectory.timestamps[frame_index];
  frame.world_from_cam = m.trajectory.world_from_cam[frame_index];
  std::vector<Quad> quads = m.static_quads;
  m.AppendWalkerQuads(m.FrameTime(frame_index), &quads);
  synth::QuadRender r = synth::RenderQuads(quads, m.textures, frame.world_from_cam.Inverse(), m.camera);
  if (m.options.depth_noise) {
    synth::KinectNoiseParams params;
    params.depth_min = m.options.depth_min;
    params.depth_max = m.options.depth_max;
    params.dropout = m.options.depth_dropout;
    params.depth_factor = m.options.depth_factor;
    frame.depth_noisy = synth::ApplyKinectNoise(r.depth, r.cos_incidence, m.camera, params,
                                                synth::Hash(m.options.seed, 0x4015e), frame_index);
  } else {
    frame.depth_noisy = r.depth;
  }
  frame.rgb = std::move(r.rgb);
  frame.depth = std::move(r.depth);
  frame.mask = std::move(r.mask);
  return frame;
}

SynthStaticView SyntheticScene::RenderStatic(const Rigid3d& world_from_cam, const Camera& camera) const {
  synth::QuadRender r =
      synth::RenderQuads(impl_->static_quads, impl_->textures, world_from_cam.Inverse(), camera);
  SynthStaticView view;
  view.rgb = std::move(r.rgb);
  view.depth = std::move(r.depth);
  return view;
}

}  // namespace dypho
