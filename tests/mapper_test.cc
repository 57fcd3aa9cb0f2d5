// The Gaussian mapper (engine/map/mapper.h) on synthetic sequences with known
// answers: insertion geometry, learning (loss falls, PSNR on trained and
// held-out views), ghost-free static maps with exact dynamic masks (and
// ghosts without them), rigid motion of anchored Gaussians when a keyframe
// pose is corrected, determinism, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "engine/eval/image_metrics.h"
#include "engine/io/image_io.h"
#include "engine/map/depth_warp.h"
#include "engine/map/map_sequence.h"
#include "engine/map/mapper.h"
#include "engine/synth/synthetic_scene.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

SynthOptions SmallScene(int walkers, int frames = 40) {
  SynthOptions o;
  o.width = 160;
  o.height = 120;
  o.frames = frames;
  o.num_walkers = walkers;
  o.depth_noise = false;
  o.motion = SynthMotion::kXyz;
  o.seed = 3;
  return o;
}

MapperOptions SmallMapper() {
  MapperOptions m;
  m.train_downscale = 1;
  m.sh_degree = 0;
  m.num_threads = 2;
  m.densify_every = 0;
  return m;
}

KeyframeInput ToKeyframe(const SynthFrame& f, bool with_mask) {
  KeyframeInput k;
  k.timestamp = f.timestamp;
  k.rgb = f.rgb;
  k.depth = f.depth_noisy;
  if (with_mask) k.dynamic_mask = f.mask;
  k.cam_from_world = f.world_from_cam.Inverse();
  return k;
}

double PsnrAt(const Mapper& mapper, const SynthFrame& f, const Camera& camera, const ImageU8& mask = ImageU8()) {
  const RenderedView view = mapper.Render(camera, f.world_from_cam.Inverse());
  ImageF color = view.color;
  for (float& v : color.pixels()) v = std::min(1.0f, std::max(0.0f, v));
  ImageU8 include;
  if (!mask.empty()) {
    include = ImageU8(mask.width(), mask.height(), 1);
    for (size_t i = 0; i < mask.size(); ++i) include.data()[i] = mask.data()[i] ? 0 : 255;
  }
  return Psnr(color, ToFloat(f.rgb), include);
}

TEST(Mapper, InsertsOneGaussianPerGridCellAtTheUnprojectedDepth) {
  // A fronto-parallel wall at z = 2 m: every Gaussian of the first keyframe
  // lies on it, at the unprojected grid pixel, with the footprint scale.
  const Camera camera{100, 100, 31.5, 23.5, 64, 48};
  MapperOptions opt = SmallMapper();
  opt.insert_stride = 4;
  Mapper mapper(camera, opt);
  KeyframeInput k;
  k.rgb = ImageU8(64, 48, 3, 128);
  k.depth = ImageF(64, 48, 1, 2.0f);
  k.cam_from_world = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.5, 0, 0));
  mapper.AddKeyframe(k);
  const GaussianCloud cloud = mapper.Cloud();
  ASSERT_EQ(cloud.size(), (64 / 4) * (48 / 4));
  const float expected_log_scale = std::log(opt.insert_scale_factor * 4 * 2.0f / 100.0f);
  for (int i = 0; i < cloud.size(); ++i) {
    // Grid pixels are (2 + 4a, 2 + 4b); world x = cam x - 0.5.
    const float x = cloud.means[3 * i] + 0.5f, y = cloud.means[3 * i + 1], z = cloud.means[3 * i + 2];
    EXPECT_NEAR(z, 2.0f, 1e-6);
    const float u = x / z * 100 + 31.5f, v = y / z * 100 + 23.5f;
    EXPECT_NEAR(std::remainder(u - 2, 4.0f), 0.0f, 1e-3) << u;
    EXPECT_NEAR(std::remainder(v - 2, 4.0f), 0.0f, 1e-3) << v;
    EXPECT_NEAR(cloud.log_scales[3 * i], expected_log_scale, 1e-5);
    EXPECT_NEAR(ShDcToRgb(cloud.sh[3 * i]), 128 / 255.0f, 1e-5);
  }
  // The same view again is explained by the map: nothing new is inserted.
  mapper.AddKeyframe(k);
  EXPECT_EQ(mapper.num_gaussians(), cloud.size());
}

TEST(Mapper, LearnsAStaticSceneAndGeneralisesToHeldOutViews) {
  const SyntheticScene scene(SmallScene(0));
  Mapper mapper(scene.camera(), SmallMapper());
  std::vector<double> losses;
  for (int i = 0; i < scene.num_frames(); i += 4) {
    mapper.AddKeyframe(ToKeyframe(scene.Render(i), true));
    losses.push_back(mapper.Optimize(30).mean_loss);
  }
  const double before_final = mapper.OptimizeAll(1).last_loss;
  const double after_final = mapper.OptimizeAll(150).mean_loss;
  EXPECT_LT(after_final, losses.front());
  EXPECT_LT(after_final, before_final * 1.05);
  double train = 0, heldout = 0;
  int nt = 0, nh = 0;
  for (int i = 0; i < scene.num_frames(); ++i) {
    const double p = PsnrAt(mapper, scene.Render(i), scene.camera());
    (i % 4 == 0 ? train : heldout) += p;
    ++(i % 4 == 0 ? nt : nh);
  }
  train /= nt;
  heldout /= nh;
  std::printf("synthetic static: train PSNR %.2f dB, held-out %.2f dB, %d Gaussians\n", train, heldout,
              mapper.num_gaussians());
  EXPECT_GT(train, 26.0);
  EXPECT_GT(heldout, 24.0);
}

// Fraction of pixels (over several views) where the map shows something in
// front of the static scene: a ghost of a walker.
double GhostFraction(const Mapper& mapper, const SyntheticScene& scene) {
  size_t ghosts = 0, total = 0;
  for (int i = 1; i < scene.num_frames(); i += 3) {
    const Rigid3d world_from_cam = scene.trajectory().world_from_cam[i];
    const SynthStaticView truth = scene.RenderStatic(world_from_cam, scene.camera());
    const RenderedView view = mapper.Render(scene.camera(), world_from_cam.Inverse());
    const ImageF depth = NormalizedDepth(view, 0.5f);
    for (size_t p = 0; p < depth.size(); ++p) {
      const float d = depth.data()[p], t = truth.depth.data()[p];
      if (!(t > 0)) continue;
      ++total;
      if (d > 0 && d < 0.85f * t) ++ghosts;
    }
  }
  return static_cast<double>(ghosts) / std::max<size_t>(1, total);
}

TEST(Mapper, ExactMasksKeepWalkersOutOfTheMapWithoutMasksTheyGhost) {
  SynthOptions so = SmallScene(3, 48);
  so.max_coverage = 0.5;
  const SyntheticScene scene(so);
  double ghost[2];
  for (int with_mask = 0; with_mask < 2; ++with_mask) {
    Mapper mapper(scene.camera(), SmallMapper());
    for (int i = 0; i < scene.num_frames(); i += 3) {
      mapper.AddKeyframe(ToKeyframe(scene.Render(i), with_mask));
      mapper.Optimize(20);
    }
    mapper.OptimizeAll(60);
    ghost[with_mask] = GhostFraction(mapper, scene);
  }
  std::printf("ghost pixels: %.4f without masks, %.4f with exact masks\n", ghost[0], ghost[1]);
  EXPECT_GT(ghost[0], 0.02) << "walkers must leave ghosts when no mask keeps them out";
  EXPECT_LT(ghost[1], 0.005) << "with exact masks the static map must be free of ghosts";
  EXPECT_GT(ghost[0], 5 * ghost[1]);
}

// Without any mask, the free-space check removes most of the walkers'
// ghosts (other keyframes see through where a walker stood) and keeps the
// static scene: the held-out PSNR on static pixels does not drop.
TEST(Mapper, FreeSpaceCarvingRemovesGhostsTheMaskMissed) {
  SynthOptions so = SmallScene(3, 48);
  so.max_coverage = 0.5;
  const SyntheticScene scene(so);
  Mapper mapper(scene.camera(), SmallMapper());
  for (int i = 0; i < scene.num_frames(); i += 4) {
    mapper.AddKeyframe(ToKeyframe(scene.Render(i), false));
    mapper.Optimize(15);
  }
  mapper.OptimizeAll(40);
  const double before = GhostFraction(mapper, scene);
  const SynthFrame heldout = scene.Render(22);
  const double psnr_before = PsnrAt(mapper, heldout, scene.camera(), heldout.mask);
  const int n = mapper.num_gaussians();
  const int carved = mapper.CarveFreeSpace();
  EXPECT_GT(carved, 0);
  EXPECT_EQ(mapper.num_gaussians(), n - carved);
  EXPECT_EQ(mapper.stats().carved, carved);
  mapper.OptimizeAll(30);
  const double after = GhostFraction(mapper, scene);
  const double psnr_after = PsnrAt(mapper, heldout, scene.camera(), heldout.mask);
  std::printf("ghost pixels %.4f -> %.4f after carving %d of %d Gaussians; static PSNR %.2f -> %.2f dB\n", before,
              after, carved, n, psnr_before, psnr_after);
  EXPECT_GT(before, 0.02);
  EXPECT_LT(after, 0.5 * before);
  EXPECT_GT(psnr_after, psnr_before - 0.5);
  EXPECT_INVALID_INPUT(mapper.CarveFreeSpace(0), "min_votes");
}

TEST(Mapper, CorrectingAKeyframePoseMovesItsGaussiansRigidly) {
  const SyntheticScene scene(SmallScene(0, 8));
  Mapper mapper(scene.camera(), SmallMapper());
  const SynthFrame f0 = scene.Render(0), f7 = scene.Render(7);
  mapper.AddKeyframe(ToKeyframe(f0, false));
  const int n0 = mapper.num_gaussians();
  mapper.AddKeyframe(ToKeyframe(f7, false));
  const GaussianCloud before = mapper.Cloud();
  const Rigid3d old_pose = mapper.KeyframePose(1);
  // The host's loop closure moves keyframe 1 by 10 cm and 3 degrees.
  const Rigid3d correction(Eigen::Quaterniond(Eigen::AngleAxisd(0.05, Eigen::Vector3d(0.3, 1, 0.2).normalized())),
                           Eigen::Vector3d(0.1, -0.02, 0.03));
  const Rigid3d new_pose = old_pose * correction;  // cam_from_world'
  mapper.SetKeyframePose(1, new_pose);
  EXPECT_TRUE(mapper.KeyframePose(1).ToMatrix().isApprox(new_pose.ToMatrix(), 1e-9));
  const GaussianCloud after = mapper.Cloud();
  const Rigid3d delta = new_pose.Inverse() * old_pose;
  for (int i = 0; i < before.size(); ++i) {
    const Eigen::Vector3d m0(before.means[3 * i], before.means[3 * i + 1], before.means[3 * i + 2]);
    const Eigen::Vector3d m1(after.means[3 * i], after.means[3 * i + 1], after.means[3 * i + 2]);
    const Eigen::Vector3d expected = i < n0 ? m0 : Eigen::Vector3d(delta * m0);
    EXPECT_LT((m1 - expected).norm(), 1e-5) << "Gaussian " << i;
  }
  // Keyframe 1's own Gaussians look the same from its new pose as before from the old one.
  Mapper only1(scene.camera(), SmallMapper());
  only1.AddKeyframe(ToKeyframe(f7, false));
  const RenderedView ref = only1.Render(scene.camera(), old_pose);
  only1.SetKeyframePose(0, new_pose);
  const RenderedView moved = only1.Render(scene.camera(), new_pose);
  EXPECT_GT(Psnr(moved.color, ref.color), 50.0);
}

// refine_poses: a keyframe given 2 cm and 1 degree off its true pose is
// moved towards it; the given pose is kept apart (KeyframeGivenPose) until
// the host sets a new one.
TEST(Mapper, RefinedKeyframePosesMoveTowardsTheTruthAndTheGivenPoseIsKept) {
  const SyntheticScene scene(SmallScene(0, 8));
  MapperOptions o = SmallMapper();
  o.refine_poses = true;
  o.lr_pose_rotation = 1e-3f;
  o.lr_pose_translation = 1e-3f;
  Mapper mapper(scene.camera(), o);
  const SynthFrame f0 = scene.Render(0), f4 = scene.Render(4), f7 = scene.Render(7);
  mapper.AddKeyframe(ToKeyframe(f0, false));
  mapper.AddKeyframe(ToKeyframe(f7, false));
  mapper.OptimizeAll(150);  // a map from the true poses
  KeyframeInput off = ToKeyframe(f4, false);
  const Rigid3d truth = off.cam_from_world;
  off.cam_from_world =
      Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 180, Eigen::Vector3d(0.2, 1, 0.1).normalized())),
              Eigen::Vector3d(0.02, -0.005, 0.0)) *
      truth;
  mapper.AddKeyframe(off);
  mapper.OptimizeAll(200);
  const Rigid3d given = mapper.KeyframeGivenPose(2), refined = mapper.KeyframePose(2);
  EXPECT_TRUE(given.ToMatrix().isApprox(off.cam_from_world.ToMatrix(), 1e-12));
  const auto error = [&](const Rigid3d& p) { return (p.Inverse().translation - truth.Inverse().translation).norm(); };
  std::printf("keyframe given %.1f mm off, refined %.1f mm off\n", 1000 * error(given), 1000 * error(refined));
  EXPECT_LT(error(refined), 0.5 * error(given));
  mapper.SetKeyframePose(2, truth);
  EXPECT_TRUE(mapper.KeyframeGivenPose(2).ToMatrix().isApprox(truth.ToMatrix(), 1e-12));
  EXPECT_TRUE(mapper.KeyframePose(2).ToMatrix().isApprox(truth.ToMatrix(), 1e-9));
}

ImageU8 ScaledRgb(const ImageU8& rgb, float gain) {
  ImageU8 out = rgb;
  for (uint8_t& v : out.pixels()) v = static_cast<uint8_t>(std::lround(std::min(255.0f, v * gain)));
  return out;
}

TEST(Mapper, RefineExposureLearnsEachKeyframesColourResponse) {
  // Every other keyframe is 30% darker (auto exposure). A global exposure is
  // unobservable (map colour times gain), and the mapper fixes it by the mean
  // response over keyframes; so the learnt responses relative to keyframe 0
  // are about 0.7 for the darker keyframes and 1 for the others, and the map
  // seen through keyframe 0's response shows the true colours.
  const SyntheticScene scene(SmallScene(0, 32));
  MapperOptions opt = SmallMapper();
  opt.refine_exposure = true;
  Mapper mapper(scene.camera(), opt);
  std::vector<float> gains;
  for (int i = 0; i < scene.num_frames(); i += 4) {
    KeyframeInput k = ToKeyframe(scene.Render(i), false);
    const float gain = (i / 4) % 2 ? 0.7f : 1.0f;
    k.rgb = ScaledRgb(k.rgb, gain);
    gains.push_back(gain);
    mapper.AddKeyframe(k);
    mapper.Optimize(30);
  }
  mapper.OptimizeAll(200);
  const ColorResponse c0 = mapper.KeyframeColorResponse(0);
  double mean_log_gain = 0;
  for (int k = 0; k < mapper.num_keyframes(); ++k) {
    const ColorResponse c = mapper.KeyframeColorResponse(k);
    for (int ch = 0; ch < 3; ++ch) {
      // Response at mid grey relative to keyframe 0's, against the truth.
      const float rel = (c.gain[ch] * 0.5f + c.bias[ch]) / (c0.gain[ch] * 0.5f + c0.bias[ch]);
      EXPECT_NEAR(rel, gains[k] / gains[0], 0.06f) << "keyframe " << k << " channel " << ch;
      mean_log_gain += std::log(c.gain[ch]) / (3.0 * mapper.num_keyframes());
    }
  }
  EXPECT_NEAR(mean_log_gain, 0.0, 0.02);  // the gauge
  double psnr = 0;
  for (int i = 2; i < scene.num_frames(); i += 4) {
    const SynthFrame f = scene.Render(i);
    ImageF color = mapper.Render(scene.camera(), f.world_from_cam.Inverse()).color;
    c0.Apply(&color);
    for (float& v : color.pixels()) v = std::min(1.0f, std::max(0.0f, v));
    psnr += Psnr(color, ToFloat(f.rgb));
  }
  psnr /= scene.num_frames() / 4;
  std::printf("exposure: held-out PSNR against the true colours through keyframe 0's response %.2f dB\n", psnr);
  EXPECT_GT(psnr, 22.0);
}

TEST(Mapper, AlignFrameRecoversAPerturbedPoseAndExposure) {
  const SyntheticScene scene(SmallScene(0));
  Mapper mapper(scene.camera(), SmallMapper());
  for (int i = 0; i < scene.num_frames(); i += 4) {
    mapper.AddKeyframe(ToKeyframe(scene.Render(i), false));
    mapper.Optimize(30);
  }
  mapper.OptimizeAll(100);
  const SynthFrame f = scene.Render(18);  // held out
  KeyframeInput in = ToKeyframe(f, false);
  in.rgb = ScaledRgb(in.rgb, 0.8f);
  const Rigid3d truth = in.cam_from_world;
  const Rigid3d offset(Eigen::Quaterniond(Eigen::AngleAxisd(0.015, Eigen::Vector3d(0.2, 1, -0.3).normalized())),
                       Eigen::Vector3d(0.01, -0.005, 0.008));
  in.cam_from_world = offset * truth;
  const GaussianCloud before = mapper.Cloud();
  const FrameAlignment a = mapper.AlignFrame(in, 100);
  const Rigid3d error = a.cam_from_world * truth.Inverse();
  const double angle = Eigen::AngleAxisd(error.rotation).angle() * 180 / M_PI;
  std::printf("align: rotation error %.3f deg (from 0.86), translation %.2f mm (from 13.7), gain %.3f %.3f %.3f, "
              "loss %.4f -> %.4f\n",
              angle, 1000 * error.translation.norm(), a.response.gain[0], a.response.gain[1], a.response.gain[2],
              a.loss_before, a.loss_after);
  EXPECT_LT(a.loss_after, 0.7 * a.loss_before);
  EXPECT_LT(angle, 0.2);
  EXPECT_LT(error.translation.norm(), 0.005);
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(a.response.gain[ch] * 0.5f + a.response.bias[ch], 0.4f, 0.04f);
  // The map itself did not change.
  const GaussianCloud after = mapper.Cloud();
  EXPECT_EQ(after.means, before.means);
  EXPECT_EQ(after.sh, before.sh);
}

TEST(Mapper, IdenticalInputGivesAnIdenticalMap) {
  const SyntheticScene scene(SmallScene(1, 12));
  GaussianCloud clouds[2];
  for (GaussianCloud& c : clouds) {
    MapperOptions opt = SmallMapper();
    opt.densify_every = 10;
    opt.densify_grad_threshold = 1e-6f;
    Mapper mapper(scene.camera(), opt);
    for (int i = 0; i < scene.num_frames(); i += 3) {
      mapper.AddKeyframe(ToKeyframe(scene.Render(i), true));
      mapper.Optimize(10);
    }
    c = mapper.Cloud();
  }
  ASSERT_EQ(clouds[0].size(), clouds[1].size());
  EXPECT_EQ(clouds[0].means, clouds[1].means);
  EXPECT_EQ(clouds[0].sh, clouds[1].sh);
  EXPECT_EQ(clouds[0].opacity_logits, clouds[1].opacity_logits);
}

TEST(Mapper, DensificationAndPruningChangeTheMap) {
  const SyntheticScene scene(SmallScene(0, 12));
  MapperOptions opt = SmallMapper();
  opt.insert_stride = 6;  // coarse: the gradient asks for more Gaussians
  opt.densify_every = 20;
  opt.densify_grad_threshold = 1e-7f;
  Mapper mapper(scene.camera(), opt);
  mapper.AddKeyframe(ToKeyframe(scene.Render(0), false));
  const int inserted = mapper.num_gaussians();
  const MapperStats s = mapper.Optimize(40);
  EXPECT_GT(s.densified, 0);
  EXPECT_GT(mapper.num_gaussians(), inserted);
  // Pruning: an opacity threshold above every Gaussian's opacity empties the map.
  MapperOptions prune = SmallMapper();
  prune.densify_every = 5;
  prune.densify_grad_threshold = 1e3f;  // no densification
  prune.prune_opacity = 0.99f;
  Mapper pruned(scene.camera(), prune);
  pruned.AddKeyframe(ToKeyframe(scene.Render(0), false));
  EXPECT_GT(pruned.num_gaussians(), 0);
  pruned.Optimize(5);
  EXPECT_EQ(pruned.num_gaussians(), 0);
  EXPECT_GT(pruned.stats().pruned, 0);
}

TEST(DepthWarp, MovesDepthToTheColourCamerasPose) {
  // A wall at z = 2 m seen by a depth camera 0.2 m to the left of the colour
  // camera (target_from_source = +0.2 m in x): every reading lands 10 px
  // (0.2 * fx / z) to the right; the left strip has no depth.
  const Camera camera{100, 100, 31.5, 23.5, 64, 48};
  const ImageF wall(64, 48, 1, 2.0f);
  const ImageF moved = WarpDepth(wall, camera, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.2, 0, 0)));
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) EXPECT_EQ(moved.at(x, y), x < 10 ? 0.0f : 2.0f) << x << "," << y;
  }
  // Moving 0.5 m towards the wall: every covered pixel reads 1.5 m.
  const ImageF nearer = WarpDepth(wall, camera, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, -0.5)));
  int covered = 0;
  for (float d : nearer.pixels()) {
    if (d > 0) {
      EXPECT_FLOAT_EQ(d, 1.5f);
      ++covered;
    }
  }
  EXPECT_GT(covered, 64 * 48 / 2);
  EXPECT_INVALID_INPUT(WarpDepth(ImageF(10, 10, 1), camera, Rigid3d()), "WarpDepth");
}

TEST(Mapper, BadInputIsAClearError) {
  const Camera camera{100, 100, 31.5, 23.5, 64, 48};
  Camera distorted = camera;
  distorted.distortion[0] = 0.1;
  EXPECT_INVALID_INPUT(Mapper(distorted, SmallMapper()), "pinhole");
  MapperOptions bad = SmallMapper();
  bad.lr_means = std::nanf("");
  EXPECT_INVALID_INPUT(Mapper(camera, bad), "lr_means");
  bad = SmallMapper();
  bad.insert_opacity = 1.0f;
  EXPECT_INVALID_INPUT(Mapper(camera, bad), "insert_opacity");
  // Device names: cpu, cuda, cuda:N (whether this build can map on a GPU is
  // engine/torch/mapper_cuda_test.cc's question).
  for (const char* device : {"gpu", "CUDA", "", "cuda:", "cuda:01", "cuda:100", "cuda:-1", "cuda0", "cuda:1 "}) {
    bad = SmallMapper();
    bad.device = device;
    EXPECT_INVALID_INPUT(Mapper(camera, bad), "mapper option device must be cpu, cuda or cuda:N");
  }
  for (const char* device : {"cpu", "cuda", "cuda:0", "cuda:7", "cuda:42"}) EXPECT_TRUE(IsMapperDevice(device)) << device;
  Mapper mapper(camera, SmallMapper());
  KeyframeInput k;
  k.rgb = ImageU8(32, 48, 3);
  EXPECT_INVALID_INPUT(mapper.AddKeyframe(k), "rgb");
  k.rgb = ImageU8(64, 48, 3);
  k.depth = ImageF(64, 40, 1);
  EXPECT_INVALID_INPUT(mapper.AddKeyframe(k), "depth");
  k.depth = ImageF(64, 48, 1, 1.0f);
  k.cam_from_world.translation.x() = std::nan("");
  EXPECT_INVALID_INPUT(mapper.AddKeyframe(k), "cam_from_world");
  EXPECT_INVALID_INPUT(mapper.SetKeyframePose(3, Rigid3d()), "keyframe 3");
  // Nothing to optimise yet: a no-op, not a crash.
  EXPECT_EQ(mapper.Optimize(5).iterations, 0);
  // A keyframe without any valid depth adds nothing (and says nothing is wrong).
  k.cam_from_world = Rigid3d();
  k.depth = ImageF(64, 48, 1, std::nanf(""));
  mapper.AddKeyframe(k);
  EXPECT_EQ(mapper.num_gaussians(), 0);
  EXPECT_EQ(mapper.Optimize(3).iterations, 0);
}

}  // namespace
}  // namespace dypho
