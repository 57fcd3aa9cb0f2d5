// The Mapper (engine/map/mapper.h) with MapperOptions::device "cuda": the
// real mapper, every tensor on the GPU, against the same mapper on the CPU.
//
// The scene: a textured room of flat Gaussians (walls, floor, ceiling, two
// boxes), rendered with the CPU rasterizer at 9 poses of a short camera path
// into RGB-D frames (256x192; the depth is the rendered depth over alpha).
// Six become keyframes; the three between them are held out.
//
// MapsOnTheGpuLikeOnTheCpu: both devices insert the keyframes and optimise
// with the same options and seed (densification and pruning included);
// each must raise the held-out PSNR by a clear margin over its start, the
// CUDA map's held-out PSNR must be within 0.5 dB of the CPU map's, and their
// sizes within 10 % (the devices round differently, so densification picks
// slightly different Gaussians). Mapper::Render on the GPU must match the
// CPU rasterizer on the same map. Prints iterations per second of both.
// EveryStageRunsOnTheGpu: the sensor model, exposure and pose refinement,
// coarse-to-fine refinement, tracker features, carving, AlignFrame,
// SetKeyframePose and SetCloud on both devices: the same answers within
// float tolerances (any tensor left on the wrong device throws).
// DeviceCudaNeedsACudaBuildAndAGpu: without a usable GPU the constructor
// throws InvalidInput naming mapper.device and the README section; with one
// it maps. It runs everywhere.
//
// The first two skip, saying "no GPU", where LibTorch sees no CUDA device or
// the build has no CUDA rasterizer; tools/gpu_check.sh counts such a skip as
// a failure on a machine with a GPU. Before skipping they run their CPU half
// and its checks (the known answer on the CPU: about 12 s on 2 cores);
// DYPHO_MAPPER_TEST_SKIP_CPU_HALF=1 skips at once.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <torch/torch.h>

#include "common/check.h"
#include "common/rigid3.h"
#include "engine/gaussians.h"
#include "engine/map/mapper.h"
#include "engine/render/render.h"
#include "kernels/rasterizer.h"

namespace dypho {
namespace {

// Why this machine cannot map on a GPU; empty when it can.
std::string NoGpuReason() {
  if (!torch::cuda::is_available()) return "LibTorch sees no CUDA device";
  std::string why;
  if (!kernels::BackendAvailable(kernels::Backend::kCuda, &why)) return "no CUDA rasterizer: " + why;
  return "";
}

const Camera kCamera{220, 220, 127.5, 95.5, 256, 192};

// Flat Gaussians covering the rectangle origin + s u + t v (s, t in [0, 1]),
// normal u x v, spacing `step` [m], coloured by `colour(p)` plus noise.
template <typename Colour>
void AddSurface(const Eigen::Vector3d& origin, const Eigen::Vector3d& u, const Eigen::Vector3d& v, double step,
                Colour colour, std::mt19937* rng, GaussianCloud* cloud) {
  std::uniform_real_distribution<double> jitter(-0.3, 0.3), noise(-0.06, 0.06);
  const Eigen::Vector3d normal = u.cross(v).normalized();
  // Rotation taking the local z axis to the normal (the disk's thin axis).
  const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), normal);
  const int nu = std::max(1, static_cast<int>(u.norm() / step)), nv = std::max(1, static_cast<int>(v.norm() / step));
  const float log_scale[3] = {std::log(0.75f * static_cast<float>(step)), std::log(0.75f * static_cast<float>(step)),
                              std::log(0.1f * static_cast<float>(step))};
  const float quat[4] = {static_cast<float>(q.w()), static_cast<float>(q.x()), static_cast<float>(q.y()),
                         static_cast<float>(q.z())};
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const Eigen::Vector3d p =
          origin + u * ((i + 0.5 + jitter(*rng)) / nu) + v * ((j + 0.5 + jitter(*rng)) / nv);
      const Eigen::Vector3d c = colour(p);
      float mean[3], sh[3];
      for (int k = 0; k < 3; ++k) {
        mean[k] = static_cast<float>(p[k]);
        sh[k] = RgbToShDc(static_cast<float>(std::clamp(c[k] + noise(*rng), 0.02, 0.98)));
      }
      cloud->Add(mean, log_scale, quat, 3.0f, sh);
    }
  }
}

// The room: the camera path stays near the origin looking along +z (y down).
GaussianCloud Room() {
  std::mt19937 rng(11);
  GaussianCloud room;
  const double s = 0.06;
  auto stripes = [](const Eigen::Vector3d& p) {
    const double a = 0.5 + 0.4 * std::sin(7.0 * p.x() + 2.0 * p.y());
    const double b = 0.5 + 0.4 * std::cos(5.0 * p.y() - 3.0 * p.z());
    return Eigen::Vector3d(a, 0.5 * (a + b), b);
  };
  auto checks = [](const Eigen::Vector3d& p) {
    const bool odd = (static_cast<int>(std::floor(2.5 * p.x())) + static_cast<int>(std::floor(2.5 * p.z()))) & 1;
    return odd ? Eigen::Vector3d(0.85, 0.8, 0.7) : Eigen::Vector3d(0.25, 0.3, 0.45);
  };
  auto rings = [](const Eigen::Vector3d& p) {
    const double r = 0.5 + 0.45 * std::sin(9.0 * std::hypot(p.x() - 0.3, p.y() + 0.2));
    return Eigen::Vector3d(0.9 * r, 0.4, 1.0 - r);
  };
  const double x0 = -2.6, x1 = 2.6, y0 = -1.7, y1 = 1.5, z0 = -0.5, z1 = 4.5;
  AddSurface({x0, y0, z1}, {x1 - x0, 0, 0}, {0, y1 - y0, 0}, s, rings, &rng, &room);     // back wall
  AddSurface({x0, y0, z0}, {0, 0, z1 - z0}, {0, y1 - y0, 0}, s, stripes, &rng, &room);   // left wall
  AddSurface({x1, y0, z0}, {0, y1 - y0, 0}, {0, 0, z1 - z0}, s, stripes, &rng, &room);   // right wall
  AddSurface({x0, y1, z0}, {x1 - x0, 0, 0}, {0, 0, z1 - z0}, s, checks, &rng, &room);    // floor
  AddSurface({x0, y0, z0}, {0, 0, z1 - z0}, {x1 - x0, 0, 0}, s, stripes, &rng, &room);   // ceiling
  // Two boxes on the floor (their front and side faces): parallax.
  auto box = [&](double cx, double cz, double w, double h, const Eigen::Vector3d& tint) {
    auto paint = [tint, stripes](const Eigen::Vector3d& p) -> Eigen::Vector3d {
      return 0.5 * tint + 0.5 * stripes(p);
    };
    AddSurface({cx - w, y1 - h, cz - w}, {2 * w, 0, 0}, {0, h, 0}, 0.04, paint, &rng, &room);
    AddSurface({cx - w, y1 - h, cz - w}, {0, h, 0}, {0, 0, 2 * w}, 0.04, paint, &rng, &room);
    AddSurface({cx + w, y1 - h, cz - w}, {0, 0, 2 * w}, {0, h, 0}, 0.04, paint, &rng, &room);
    AddSurface({cx - w, y1 - h, cz - w}, {0, 0, 2 * w}, {2 * w, 0, 0}, 0.04, paint, &rng, &room);
  };
  box(-0.9, 2.6, 0.35, 0.9, {0.9, 0.2, 0.1});
  box(1.0, 3.2, 0.45, 1.4, {0.1, 0.7, 0.3});
  return room;
}

// Camera i of the path (world_from_cam): a sideways sweep with a turn.
Rigid3d WorldFromCam(int i) {
  const double yaw = 0.05 * (i - 4), pitch = 0.02 * std::sin(i);
  const Eigen::Quaterniond r(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()));
  return Rigid3d(r, Eigen::Vector3d(0.09 * (i - 4), 0.03 * std::cos(i), 0.04 * i));
}

struct Frame {
  KeyframeInput input;  // what the mapper takes
  ImageF colour;        // the truth, float [0, 1]
};

Frame RenderFrame(const GaussianCloud& truth, int i) {
  const Rigid3d cam_from_world = WorldFromCam(i).Inverse();
  const RenderedView v = RenderView(truth, kCamera, cam_from_world, kernels::RasterSettings());
  Frame f;
  f.colour = v.color;
  f.input.timestamp = 0.1 * i;
  f.input.cam_from_world = cam_from_world;
  f.input.rgb = ImageU8(kCamera.width, kCamera.height, 3);
  for (size_t p = 0; p < v.color.size(); ++p) {
    f.colour.data()[p] = std::clamp(v.color.data()[p], 0.0f, 1.0f);
    f.input.rgb.data()[p] = static_cast<uint8_t>(std::lround(255.0f * f.colour.data()[p]));
  }
  f.input.depth = NormalizedDepth(v, 0.5f);
  return f;
}

double Psnr(const ImageF& a, const ImageF& b) {
  double se = 0;
  for (size_t p = 0; p < a.size(); ++p) {
    const double d = std::clamp(a.data()[p], 0.0f, 1.0f) - b.data()[p];
    se += d * d;
  }
  return -10.0 * std::log10(std::max(se / a.size(), 1e-12));
}

struct Scene {
  std::vector<Frame> keyframes, held_out;
};

const Scene& TheScene() {
  static const Scene scene = [] {
    const GaussianCloud truth = Room();
    Scene s;
    for (int i = 0; i <= 10; ++i) {
      if (i % 2 == 0) {
        s.keyframes.push_back(RenderFrame(truth, i));
      } else if (i % 4 == 1) {
        s.held_out.push_back(RenderFrame(truth, i));
      }
    }
    return s;
  }();
  return scene;
}

kernels::RasterSettings RenderSettings(const MapperOptions& o) {
  kernels::RasterSettings s;
  s.sh_degree = o.sh_degree;
  for (float& b : s.background) b = o.background;
  return s;
}

// Mean PSNR of the held-out views, rendered by the CPU rasterizer from the
// map's host copy (the same renderer for either device).
double HeldOutPsnr(const Mapper& mapper) {
  const GaussianCloud cloud = mapper.Cloud();
  double sum = 0;
  for (const Frame& f : TheScene().held_out) {
    sum += Psnr(RenderView(cloud, kCamera, f.input.cam_from_world, RenderSettings(mapper.options())).color, f.colour);
  }
  return sum / TheScene().held_out.size();
}

MapperOptions TestOptions(const std::string& device) {
  MapperOptions o;
  o.device = device;
  o.train_downscale = 1;
  o.sh_degree = 0;
  o.densify_every = 100;  // densification and pruning run in the test
  o.seed = 5;
  return o;
}

constexpr int kIterations = 300;
// [dB] held-out PSNR over the start: the CPU gains 10.3 (23.01 -> 33.35 dB).
constexpr double kMinGain = 5.0;

struct MapRun {
  std::unique_ptr<Mapper> mapper;
  double psnr_start = 0, psnr_end = 0;  // [dB] held out, after insertion and after optimisation
  double iterations_per_second = 0;
};

// Inserts the keyframes, then optimises over all of them.
MapRun MapOn(const std::string& device) {
  MapRun r;
  r.mapper = std::make_unique<Mapper>(kCamera, TestOptions(device));
  for (const Frame& f : TheScene().keyframes) r.mapper->AddKeyframe(f.input);
  r.psnr_start = HeldOutPsnr(*r.mapper);
  const MapperStats s = r.mapper->OptimizeAll(kIterations);
  r.iterations_per_second = kIterations / s.optimize_seconds;
  r.psnr_end = HeldOutPsnr(*r.mapper);
  std::printf("[ mapper    ] %-4s: %d keyframes, %d Gaussians (densified %d, pruned %d), %d steps at %.1f it/s; "
              "held-out PSNR %.2f -> %.2f dB\n",
              device.c_str(), r.mapper->num_keyframes(), r.mapper->num_gaussians(), s.densified, s.pruned, kIterations,
              r.iterations_per_second, r.psnr_start, r.psnr_end);
  return r;
}

bool AllFinite(const GaussianCloud& c) {
  for (const std::vector<float>* v : {&c.means, &c.log_scales, &c.quats, &c.opacity_logits, &c.sh}) {
    if (!std::all_of(v->begin(), v->end(), [](float x) { return std::isfinite(x); })) return false;
  }
  return true;
}

// Without a GPU the CPU half runs first unless DYPHO_MAPPER_TEST_SKIP_CPU_HALF=1.
bool CpuHalfWithoutGpu() {
  const char* skip = std::getenv("DYPHO_MAPPER_TEST_SKIP_CPU_HALF");
  return !(skip != nullptr && std::string(skip) == "1");
}

TEST(MapperCuda, MapsOnTheGpuLikeOnTheCpu) {
  const std::string no_gpu = NoGpuReason();
  if (!no_gpu.empty() && !CpuHalfWithoutGpu()) GTEST_SKIP() << "no GPU: " << no_gpu;
  const MapRun cpu = MapOn("cpu");
  EXPECT_GT(cpu.psnr_end, cpu.psnr_start + kMinGain);
  EXPECT_TRUE(AllFinite(cpu.mapper->Cloud()));
  if (!no_gpu.empty()) GTEST_SKIP() << "no GPU: " << no_gpu << " (the CPU half ran first: its checks are above)";

  const MapRun gpu = MapOn("cuda");
  EXPECT_GT(gpu.psnr_end, gpu.psnr_start + kMinGain);
  // Insertion renders the growing map to find unexplained pixels: the same
  // map to within a few pixels' worth of Gaussians.
  EXPECT_NEAR(gpu.psnr_start, cpu.psnr_start, 0.2);
  EXPECT_NEAR(gpu.psnr_end, cpu.psnr_end, 0.5);
  EXPECT_NEAR(gpu.mapper->num_gaussians(), cpu.mapper->num_gaussians(), 0.1 * cpu.mapper->num_gaussians());
  const GaussianCloud cloud = gpu.mapper->Cloud();
  EXPECT_EQ(cloud.size(), gpu.mapper->num_gaussians());
  EXPECT_TRUE(AllFinite(cloud));
  // Render on the GPU (the op on the map's CUDA tensors) against the CPU
  // rasterizer on its host copy: tests/cuda_parity_test.cc's tolerances.
  for (const Frame& f : TheScene().held_out) {
    const RenderedView on_gpu = gpu.mapper->Render(kCamera, f.input.cam_from_world);
    const RenderedView on_cpu =
        RenderView(cloud, kCamera, f.input.cam_from_world, RenderSettings(gpu.mapper->options()));
    size_t over = 0;
    float worst = 0;
    for (size_t p = 0; p < on_cpu.color.size(); ++p) {
      const float d = std::abs(on_gpu.color.data()[p] - on_cpu.color.data()[p]);
      over += d > 1e-4f;
      worst = std::max(worst, d);
    }
    EXPECT_LE(over, on_cpu.color.size() / 200);
    EXPECT_LT(worst, 5e-2f);
    EXPECT_EQ(on_gpu.stats.num_gaussians, cloud.size());
  }
  std::printf("[ mapper    ] GPU/CPU speed: %.1fx; held-out PSNR difference %+.3f dB\n",
              gpu.iterations_per_second / cpu.iterations_per_second, gpu.psnr_end - cpu.psnr_end);
  RecordProperty("cpu_iterations_per_second", std::to_string(cpu.iterations_per_second));
  RecordProperty("gpu_iterations_per_second", std::to_string(gpu.iterations_per_second));
}

// What EveryStageRunsOnTheGpu compares between the devices.
struct StageResults {
  int gaussians = 0, carved = 0;
  double loss = 0;
  Rigid3d moved_pose;  // KeyframePose(2) after SetKeyframePose
  FrameAlignment aligned;
  ColorResponse response;
  bool finite = false, set_cloud_round_trip = false;
};

StageResults RunEveryStage(const std::string& device) {
  MapperOptions o = TestOptions(device);
  o.train_downscale = 2;
  o.refine_exposure = true;
  o.refine_poses = true;
  o.refine_downscale = 1;  // the final steps at full resolution (images made from the compact copies)
  o.sensor.readout = 0.02;
  o.sensor.exposure = 0.01;
  o.sharp_sampling_floor = 0.5;
  o.densify_every = 25;
  Mapper m(kCamera, o);
  const Scene& scene = TheScene();
  for (size_t k = 0; k < 4; ++k) {
    KeyframeInput in = scene.keyframes[k].input;
    in.angular_velocity = Eigen::Vector3d(0.3, -0.2, 0.1);
    for (int y = 10; y < kCamera.height; y += 37) {
      for (int x = 7; x < kCamera.width; x += 41) in.features.push_back({x + 0.3f, y - 0.2f, in.depth.at(x, y)});
    }
    if (k == 1) {  // a dynamic box
      in.dynamic_mask = ImageU8(kCamera.width, kCamera.height, 1, 0);
      for (int y = 40; y < 90; ++y) {
        for (int x = 100; x < 160; ++x) in.dynamic_mask.at(x, y) = 1;
      }
    }
    m.AddKeyframe(in);
    m.Optimize(15);
  }
  m.OptimizeAll(30);
  StageResults r;
  r.carved = m.CarveFreeSpace(2);
  r.moved_pose = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitX())),
                         Eigen::Vector3d(0.01, 0, 0)) * m.KeyframePose(2);
  m.SetKeyframePose(2, r.moved_pose);
  KeyframeInput frame = scene.held_out[0].input;
  frame.cam_from_world =
      Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.004, Eigen::Vector3d::UnitY())), Eigen::Vector3d(0.01, 0, 0)) *
      frame.cam_from_world;
  r.aligned = m.AlignFrame(frame, 20);
  r.response = m.KeyframeColorResponse(1);
  r.loss = m.MeanKeyframeLoss();
  r.gaussians = m.num_gaussians();
  const GaussianCloud cloud = m.Cloud();
  r.finite = AllFinite(cloud);
  Mapper copy(kCamera, o);
  copy.SetCloud(cloud);
  const GaussianCloud back = copy.Cloud();
  r.set_cloud_round_trip = back.means == cloud.means && back.sh == cloud.sh && back.quats == cloud.quats &&
                           back.log_scales == cloud.log_scales && back.opacity_logits == cloud.opacity_logits;
  EXPECT_NEAR((m.KeyframePose(2).translation - r.moved_pose.translation).norm(), 0.0, 1e-6) << device;
  std::printf("[ stages    ] %-4s: %d Gaussians, carved %d, mean keyframe loss %.4f, align loss %.4f -> %.4f, "
              "keyframe 1 gain %.3f %.3f %.3f\n",
              device.c_str(), r.gaussians, r.carved, r.loss, r.aligned.loss_before, r.aligned.loss_after,
              r.response.gain[0], r.response.gain[1], r.response.gain[2]);
  return r;
}

void ExpectSane(const StageResults& r) {
  EXPECT_TRUE(r.finite);
  EXPECT_TRUE(r.set_cloud_round_trip);
  EXPECT_LT(r.aligned.loss_after, r.aligned.loss_before);
  EXPECT_GT(r.gaussians, 1000);
}

TEST(MapperCuda, EveryStageRunsOnTheGpu) {
  const std::string no_gpu = NoGpuReason();
  if (!no_gpu.empty() && !CpuHalfWithoutGpu()) GTEST_SKIP() << "no GPU: " << no_gpu;
  const StageResults cpu = RunEveryStage("cpu");
  ExpectSane(cpu);
  if (!no_gpu.empty()) GTEST_SKIP() << "no GPU: " << no_gpu << " (the CPU half ran first: its checks are above)";
  const StageResults gpu = RunEveryStage("cuda");
  ExpectSane(gpu);
  EXPECT_NEAR(gpu.gaussians, cpu.gaussians, 0.1 * cpu.gaussians);
  EXPECT_NEAR(gpu.loss, cpu.loss, 0.1 * cpu.loss);
  EXPECT_NEAR((gpu.aligned.cam_from_world.translation - cpu.aligned.cam_from_world.translation).norm(), 0.0, 5e-3);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(gpu.response.gain[c], cpu.response.gain[c], 0.05) << "channel " << c;
}

TEST(MapperCuda, DeviceCudaNeedsACudaBuildAndAGpu) {
  MapperOptions o = TestOptions("cuda");
  const std::string no_gpu = NoGpuReason();
  if (no_gpu.empty()) {
    // A GPU: "cuda" maps; an index past the devices is named.
    Mapper m(kCamera, o);
    m.AddKeyframe(TheScene().keyframes[0].input);
    EXPECT_GT(m.num_gaussians(), 1000);
    EXPECT_GT(m.Optimize(3).iterations, 0);
    EXPECT_EQ(m.Cloud().size(), m.num_gaussians());
    const int count = static_cast<int>(torch::cuda::device_count());
    if (count <= 99) {
      o.device = "cuda:" + std::to_string(count);
      try {
        Mapper past(kCamera, o);
        ADD_FAILURE() << o.device << " was accepted with " << count << " device(s)";
      } catch (const InvalidInput& e) {
        EXPECT_NE(std::string(e.what()).find("mapper.device is '" + o.device + "', but LibTorch sees"),
                  std::string::npos)
            << e.what();
      }
    }
    return;
  }
  // No usable GPU: a clear error naming the option, the reason and the fix.
  const std::string reason = !at::hasCUDA()                  ? "is a CPU-only build"
                             : !torch::cuda::is_available() ? "LibTorch sees no CUDA device"
                                                            : "the CUDA rasterizer is unavailable";
  for (const std::string device : {"cuda", "cuda:3"}) {
    o.device = device;
    try {
      Mapper m(kCamera, o);
      ADD_FAILURE() << "mapper.device=" << device << " was accepted without a GPU (" << no_gpu << ")";
    } catch (const InvalidInput& e) {
      const std::string what = e.what();
      for (const std::string& needle : {"mapper.device is '" + device + "'", reason, std::string("mapper.device=cpu"),
                                        std::string("\"Building with an NVIDIA GPU (CUDA)\"")}) {
        EXPECT_NE(what.find(needle), std::string::npos) << "'" << needle << "' not in: " << what;
      }
    }
  }
}

}  // namespace
}  // namespace dypho
