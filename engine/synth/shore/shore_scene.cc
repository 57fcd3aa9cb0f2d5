#include "engine/synth/shore/shore_scene.h"

#include <algorithm>
#include <cmath>

#include "common/check.h"
#include "engine/synth/quad_renderer.h"
#include "engine/synth/random.h"
#include "engine/synth/shore/shore_layout.h"
#include "engine/synth/shore/shore_motion.h"
#include "engine/synth/shore/shore_movers.h"
#include "engine/synth/shore/water_sky.h"
#include "engine/synth/texture.h"
#include "engine/synth/walker.h"
#include "engine/synth/walker_look.h"

namespace dypho {
namespace {

using Eigen::Vector3d;
using synth::Material;
using synth::PaintStyle;
using synth::Quad;

constexpr double kShoreTexels = 50.0;   // buildings, quay [texels per metre]
constexpr double kSmallTexels = 120.0;  // trees, dock, bollards, boat
constexpr double kHiddenTexels = 2.0;   // faces never seen (backs, bottoms)
constexpr double kWalkerTexels = 200.0;

// Lambertian shading from the sun (high, behind the shore, to the left) plus sky light.
float Shade(const Vector3d& normal) {
  static const Vector3d kSun = Vector3d(-0.35, 0.45, 0.82).normalized();
  const double d = normal.dot(kSun);
  return static_cast<float>(0.55 + 0.45 * std::max(0.0, d) + 0.1 * std::max(0.0, -d));
}

struct TextureJob {
  PaintStyle style;
  double width_m, height_m, texels_per_m;
  double hue, saturation;  // recolour; saturation < 0: keep the painted colours
};

}  // namespace

struct ShoreScene::Impl {
  ShoreSynthOptions options;
  Camera camera;
  Trajectory trajectory;
  synth::WaterSky water_sky{1};
  std::vector<synth::Texture> textures;
  std::vector<Quad> static_quads;
  std::vector<SynthBox> static_boxes;
  std::vector<synth::WalkerBody> bodies;
  std::vector<synth::WalkerPlan> plans;
  std::vector<std::array<std::array<int, synth::kBoxFaces>, synth::kNumWalkerParts>> walker_textures;
  std::array<std::array<int, synth::kBoxFaces>, synth::kBoatParts> boat_textures{};

  double FrameTime(int i) const { return i / options.fps; }

  void AppendDynamicQuads(double t, std::vector<Quad>* quads) const {
    for (size_t k = 0; k < plans.size(); ++k) {
      const auto poses = synth::PedestrianPartPoses(bodies[k], plans[k].StateAt(t));
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
    if (!options.boat) return;
    const auto parts = synth::BoatPartsAt(options, t);
    for (int p = 0; p < synth::kBoatParts; ++p) {
      const auto faces = synth::BoxQuads(parts[p].world_from_box, parts[p].size);
      for (int f = 0; f < synth::kBoxFaces; ++f) {
        Quad q = faces[f];
        q.texture = boat_textures[p][f];
        q.shade = Shade(q.normal);
        q.object = static_cast<int>(plans.size());
        quads->push_back(q);
      }
    }
  }

  // Renders quads, then water and sky where the ray meets the water plane
  // first or nothing at all. Fills rgb (when `colour`), depth and the masks.
  void Render(const std::vector<Quad>& quads, const Rigid3d& world_from_cam, const Camera& cam, double t,
              bool colour, ShoreFrame* out) const {
    synth::QuadRender r = synth::RenderQuads(quads, textures, world_from_cam.Inverse(), cam, colour);
    const int w = cam.width, h = cam.height;
    out->water = ImageU8(w, h, 1, 0);
    out->sky = ImageU8(w, h, 1, 0);
    out->dynamic = std::move(r.mask);
    const Eigen::Matrix3d rot = world_from_cam.rotation.toRotationMatrix();
    const Vector3d& c = world_from_cam.translation;
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        float& z = r.depth.at(u, v);
        const Vector3d ray_cam((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
        const Vector3d ray = rot * ray_cam;  // world, camera z = 1
        const double z_water = ray.z() < 0 ? c.z() / -ray.z() : 0.0;
        const Vector3d dir = ray.normalized();
        if (z_water > 0 && (z <= 0 || z_water < z)) {
          out->water.at(u, v) = 255;
          out->dynamic.at(u, v) = 0;
          z = 0;
          if (colour) {
            const Vector3d p = c + z_water * ray;
            const double range = z_water * ray.norm();
            const double footprint = range / cam.fx / std::sqrt(std::max(std::abs(dir.z()), 0.02));
            const Eigen::Vector3f col = water_sky.Water(p, dir, footprint, t);
            for (int k = 0; k < 3; ++k) r.rgb.at(u, v, k) = static_cast<uint8_t>(std::lround(255.0f * col[k]));
          }
        } else if (z <= 0) {
          out->sky.at(u, v) = 255;
          if (colour) {
            const Eigen::Vector3f col = water_sky.Sky(dir, t);
            for (int k = 0; k < 3; ++k) r.rgb.at(u, v, k) = static_cast<uint8_t>(std::lround(255.0f * col[k]));
          }
        } else if (z > options.depth_max) {
          z = 0;
        }
      }
    }
    out->rgb = std::move(r.rgb);
    out->depth = std::move(r.depth);
  }
};

ShoreScene::ShoreScene(const ShoreSynthOptions& options) : impl_(std::make_unique<Impl>()) {
  options.Validate();
  Impl& m = *impl_;
  m.options = options;
  m.camera = options.MakeCamera();
  m.camera.Validate("shore sequence options");
  m.trajectory = synth::ShoreTrajectory(options);
  m.water_sky = synth::WaterSky(options.seed);

  std::vector<TextureJob> jobs;
  auto style = [](Material material) {
    PaintStyle s;
    s.material = material;
    return s;
  };
  // Static shore: box faces +x, -x, +y, -y, +z, -z; the camera looks along
  // +y, so +y and -z faces are never seen.
  for (const synth::ShoreBox& b : synth::ShoreLayout(options.seed)) {
    const auto faces = synth::BoxQuads(b.world_from_box, b.size);
    const auto sizes = synth::BoxFaceSizes(b.size);
    const double texels = b.size.maxCoeff() > 4.0 ? kShoreTexels : kSmallTexels;
    for (int f = 0; f < synth::kBoxFaces; ++f) {
      Quad q = faces[f];
      q.shade = Shade(q.normal);
      const bool top = f >= 4;
      const double hue = top ? b.top_hue : b.hue;
      if (b.textured) {
        q.texture = static_cast<int>(jobs.size());
        const bool hidden = f == 2 || f == 5;
        jobs.push_back({style(top ? b.top_material : b.material), sizes[f].x(), sizes[f].y(),
                        hidden ? kHiddenTexels : texels, hue, b.saturation});
      } else {
        q.colour = synth::HsvToRgb(hue, b.saturation, 0.85);
      }
      m.static_quads.push_back(q);
    }
    m.static_boxes.push_back({b.world_from_box, b.size, -1});
  }
  // Pedestrians.
  m.plans = synth::PlanPedestrians(options);
  for (int k = 0; k < options.num_pedestrians; ++k) {
    const synth::WalkerLook look = synth::MakeWalkerLook(k, options.seed);
    m.bodies.emplace_back(look.scale);
    std::array<std::array<int, synth::kBoxFaces>, synth::kNumWalkerParts> ids;
    for (int p = 0; p < synth::kNumWalkerParts; ++p) {
      const auto sizes = synth::BoxFaceSizes(m.bodies.back().size[p]);
      for (int f = 0; f < synth::kBoxFaces; ++f) {
        ids[p][f] = static_cast<int>(jobs.size());
        jobs.push_back({look.styles[p][f], sizes[f].x(), sizes[f].y(), kWalkerTexels, 0.0, -1.0});
      }
    }
    m.walker_textures.push_back(ids);
  }
  // The boat: a red hull with white-blue trim pattern, a cream cabin with windows.
  if (options.boat) {
    const auto parts = synth::BoatPartsAt(options, 0.0);
    for (int p = 0; p < synth::kBoatParts; ++p) {
      const auto sizes = synth::BoxFaceSizes(parts[p].size);
      for (int f = 0; f < synth::kBoxFaces; ++f) {
        m.boat_textures[p][f] = static_cast<int>(jobs.size());
        jobs.push_back({style(p == 0 ? Material::kCabinet : Material::kScreen), sizes[f].x(), sizes[f].y(),
                        kSmallTexels, p == 0 ? 0.0 : 0.11, p == 0 ? 0.75 : 0.45});
      }
    }
  }
  m.textures.resize(jobs.size());
  const uint64_t texture_seed = synth::Hash(options.seed, 0x5a0e7e);
#pragma omp parallel for schedule(dynamic, 1)
  for (int i = 0; i < static_cast<int>(jobs.size()); ++i) {
    const TextureJob& job = jobs[i];
    synth::Texture t = synth::PaintTexture(job.style, job.width_m, job.height_m, job.texels_per_m,
                                           synth::Hash(texture_seed, static_cast<uint64_t>(i)));
    m.textures[i] = job.saturation >= 0 ? synth::Recolour(t, job.hue, job.saturation) : std::move(t);
  }
}

ShoreScene::~ShoreScene() = default;

const ShoreSynthOptions& ShoreScene::options() const { return impl_->options; }
const Camera& ShoreScene::camera() const { return impl_->camera; }
const Trajectory& ShoreScene::trajectory() const { return impl_->trajectory; }
int ShoreScene::num_frames() const { return impl_->options.frames; }
const std::vector<SynthBox>& ShoreScene::static_boxes() const { return impl_->static_boxes; }

std::vector<SynthBox> ShoreScene::dynamic_boxes(int frame_index) const {
  DYPHO_CHECK_INPUT(frame_index >= 0 && frame_index < num_frames())
      << "frame_index " << frame_index << " is outside [0, " << num_frames() << ")";
  const Impl& m = *impl_;
  const double t = m.FrameTime(frame_index);
  std::vector<SynthBox> out;
  for (size_t k = 0; k < m.plans.size(); ++k) {
    const auto poses = synth::PedestrianPartPoses(m.bodies[k], m.plans[k].StateAt(t));
    for (int p = 0; p < synth::kNumWalkerParts; ++p) out.push_back({poses[p], m.bodies[k].size[p], int(k)});
  }
  if (m.options.boat) {
    for (const synth::BoatPart& p : synth::BoatPartsAt(m.options, t)) {
      out.push_back({p.world_from_box, p.size, static_cast<int>(m.plans.size())});
    }
  }
  return out;
}

ShoreFrame ShoreScene::Render(int frame_index) const {
  DYPHO_CHECK_INPUT(frame_index >= 0 && frame_index < num_frames())
      << "frame_index " << frame_index << " is outside [0, " << num_frames() << ")";
  const Impl& m = *impl_;
  ShoreFrame frame;
  frame.index = frame_index;
  frame.timestamp = m.trajectory.timestamps[frame_index];
  frame.world_from_cam = m.trajectory.world_from_cam[frame_index];
  const double t = m.FrameTime(frame_index);
  std::vector<Quad> quads = m.static_quads;
  m.AppendDynamicQuads(t, &quads);
  m.Render(quads, frame.world_from_cam, m.camera, t, true, &frame);
  if (m.options.stereo) {
    const Rigid3d world_from_right =
        frame.world_from_cam * Rigid3d(Eigen::Quaterniond::Identity(), Vector3d(m.options.baseline, 0, 0));
    ShoreFrame right;
    m.Render(quads, world_from_right, m.camera, t, true, &right);
    frame.right_rgb = std::move(right.rgb);
  }
  return frame;
}

SynthStaticView ShoreScene::RenderStatic(const Rigid3d& world_from_cam, const Camera& camera, double t) const {
  ShoreFrame f;
  impl_->Render(impl_->static_quads, world_from_cam, camera, t, true, &f);
  SynthStaticView view;
  view.rgb = std::move(f.rgb);
  view.depth = std::move(f.depth);
  return view;
}

}  // namespace dypho
