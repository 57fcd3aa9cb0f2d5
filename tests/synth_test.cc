// Tests of the synthetic dynamic RGB-D sequence generator (engine/synth).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/check.h"
#include "common/files.h"
#include "engine/dataset/dataset.h"
#include "engine/eval/trajectory.h"
#include "engine/io/image_io.h"
#include "engine/synth/camera_motion.h"
#include "engine/synth/depth_noise.h"
#include "engine/synth/quad_renderer.h"
#include "engine/synth/scene_layout.h"
#include "engine/synth/synthetic_scene.h"
#include "tests/synth_test_options.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;
using synth_testing::Coverage;
using synth_testing::kDeg;
using synth_testing::SmallOptions;

std::string FileBytes(const std::string& path) { return ReadTextFile(path); }

// Lines of a list file without comments, split into fields.
std::vector<std::vector<std::string>> ReadList(const std::string& path) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(ReadTextFile(path));
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::vector<std::string> row;
    std::string f;
    while (fields >> f) row.push_back(f);
    rows.push_back(row);
  }
  return rows;
}

// ---------------------------------------------------------------------------
// Options

TEST(SynthOptionsTest, DefaultsAreValidAndCameraScales) {
  SynthOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error)) << error;
  const Camera c = o.MakeCamera();
  EXPECT_EQ(c.fx, 525.0);
  EXPECT_EQ(c.fy, 525.0);
  EXPECT_EQ(c.cx, 319.5);
  EXPECT_EQ(c.cy, 239.5);
  const Camera small = SmallOptions().MakeCamera();
  EXPECT_EQ(small.width, 160);
  EXPECT_EQ(small.height, 120);
  EXPECT_EQ(small.fx, 131.25);
  EXPECT_EQ(small.cx, 79.5);
  EXPECT_EQ(small.cy, 59.5);
  SynthOptions wide;
  wide.width = 320;
  wide.height = 180;
  const Camera w = wide.MakeCamera();
  EXPECT_EQ(w.fx, 262.5);  // square pixels
  EXPECT_EQ(w.fy, 262.5);
  EXPECT_EQ(w.cx, 159.5);
  EXPECT_EQ(w.cy, 89.5);
  for (SynthMotion m :
       {SynthMotion::kXyz, SynthMotion::kRpy, SynthMotion::kHalfsphere, SynthMotion::kStatic,
        SynthMotion::kLoop}) {
    SynthMotion parsed = SynthMotion::kStatic;
    ASSERT_TRUE(ParseSynthMotion(SynthMotionName(m), &parsed));
    EXPECT_EQ(parsed, m);
  }
  SynthMotion unused;
  EXPECT_FALSE(ParseSynthMotion("circle", &unused));
}

TEST(SynthOptionsTest, BadOptionsNameTheField) {
  struct Case {
    std::string field;
    std::function<void(SynthOptions&)> change;
  };
  const std::vector<Case> cases = {
      {"width", [](SynthOptions& o) { o.width = 0; }},
      {"height", [](SynthOptions& o) { o.height = -4; }},
      {"frames", [](SynthOptions& o) { o.frames = 0; }},
      {"fps", [](SynthOptions& o) { o.fps = std::nan(""); }},
      {"start_time", [](SynthOptions& o) { o.start_time = -1.0; }},
      {"num_walkers", [](SynthOptions& o) { o.num_walkers = 5; }},
      {"num_walkers", [](SynthOptions& o) { o.num_walkers = -1; }},
      {"walker_speed", [](SynthOptions& o) { o.walker_speed = 0.0; }},
      {"max_coverage", [](SynthOptions& o) { o.max_coverage = 0.0; }},
      {"max_coverage", [](SynthOptions& o) { o.max_coverage = 1.5; }},
      {"depth_min", [](SynthOptions& o) { o.depth_min = -0.1; }},
      {"depth_max", [](SynthOptions& o) { o.depth_max = 0.2; }},
      {"depth_dropout", [](SynthOptions& o) { o.depth_dropout = 1.0; }},
      {"depth_factor", [](SynthOptions& o) { o.depth_factor = 0.0; }},
      {"fx", [](SynthOptions& o) { o.fx = -525.0; }},
      {"fy", [](SynthOptions& o) { o.fy = INFINITY; }},
      {"cx", [](SynthOptions& o) { o.cx = std::nan(""); }},
      {"motion", [](SynthOptions& o) { o.motion = static_cast<SynthMotion>(17); }},
  };
  for (const Case& c : cases) {
    SynthOptions o = SmallOptions();
    c.change(o);
    std::string error;
    EXPECT_FALSE(o.IsValid(&error)) << c.field;
    EXPECT_NE(error.find(c.field), std::string::npos) << "'" << error << "' does not name " << c.field;
    try {
      SyntheticScene scene(o);
      ADD_FAILURE() << "no exception for bad " << c.field;
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(c.field), std::string::npos) << e.what();
    }
    EXPECT_THROW(WriteSyntheticSequence(o, testing::TestTempDir()), InvalidInput) << c.field;
  }
}

TEST(SynthOptionsTest, UnreachableCoverageNamesMaxCoverage) {
  SynthOptions o = SmallOptions(1, 4, SynthMotion::kXyz, 10);
  o.max_coverage = 0.02;
  try {
    SyntheticScene scene(o);
    ADD_FAILURE() << "4 walkers cannot stay under 2% of the image";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("max_coverage"), std::string::npos) << e.what();
  }
}

TEST(SynthSceneTest, RenderRejectsBadFrameIndexAndDistortedCamera) {
  const SyntheticScene scene(SmallOptions(1, 1, SynthMotion::kStatic, 2));
  EXPECT_THROW(scene.Render(-1), InvalidInput);
  EXPECT_THROW(scene.Render(2), InvalidInput);
  Camera distorted = scene.camera();
  distorted.distortion[0] = 0.1;
  EXPECT_THROW(scene.RenderStatic(scene.trajectory().world_from_cam[0], distorted), InvalidInput);
}

// ---------------------------------------------------------------------------
// Trajectories

// Yaw, pitch, roll [rad] of R = R_y(-yaw) R_x(pitch) R_z(roll) (the presets'
// convention, camera frame: y down).
Vector3d YawPitchRoll(const Eigen::Matrix3d& R) {
  const double a = std::atan2(R(0, 2), R(2, 2));
  const double b = -std::asin(std::clamp(R(1, 2), -1.0, 1.0));
  const double c = std::atan2(R(1, 0), R(1, 1));
  return Vector3d(-a, b, c);
}

struct TrajectoryStats {
  Vector3d min_t = Vector3d::Constant(1e9), max_t = Vector3d::Constant(-1e9);
  Vector3d max_abs_ypr = Vector3d::Zero();
  double max_speed = 0.0, max_accel = 0.0, max_angular_speed = 0.0;
};

TrajectoryStats Analyse(const Trajectory& traj, double fps) {
  TrajectoryStats s;
  const Eigen::Matrix3d base =
      synth::LookAt(synth::CameraHome(), synth::LookTarget()).rotation.toRotationMatrix();
  const double dt = 1.0 / fps;
  for (size_t i = 0; i < traj.size(); ++i) {
    const Rigid3d& p = traj.world_from_cam[i];
    s.min_t = s.min_t.cwiseMin(p.translation);
    s.max_t = s.max_t.cwiseMax(p.translation);
    s.max_abs_ypr =
        s.max_abs_ypr.cwiseMax(YawPitchRoll(base.transpose() * p.rotation.toRotationMatrix()).cwiseAbs());
    if (i > 0) {
      const Rigid3d& q = traj.world_from_cam[i - 1];
      s.max_speed = std::max(s.max_speed, (p.translation - q.translation).norm() / dt);
      s.max_angular_speed = std::max(s.max_angular_speed, RotationAngle(p.rotation, q.rotation) / dt);
    }
    if (i > 0 && i + 1 < traj.size()) {
      const Vector3d a = traj.world_from_cam[i + 1].translation - 2.0 * p.translation +
                         traj.world_from_cam[i - 1].translation;
      s.max_accel = std::max(s.max_accel, a.norm() / (dt * dt));
    }
  }
  return s;
}

TEST(SynthTrajectoryTest, PresetsAreSmoothAndHaveTheirShape) {
  for (SynthMotion motion :
       {SynthMotion::kXyz, SynthMotion::kRpy, SynthMotion::kHalfsphere, SynthMotion::kStatic,
        SynthMotion::kLoop}) {
    SCOPED_TRACE(SynthMotionName(motion));
    SynthOptions o = SmallOptions(21, 1, motion, 300);  // 10 s
    const Trajectory traj = MakeSynthTrajectory(o);
    ASSERT_EQ(traj.size(), 300u);
    for (size_t i = 1; i < traj.size(); ++i) ASSERT_GT(traj.timestamps[i], traj.timestamps[i - 1]);
    EXPECT_DOUBLE_EQ(traj.timestamps[0], o.start_time);
    const TrajectoryStats s = Analyse(traj, o.fps);
    // Smooth: hand-held speeds, no jumps.
    EXPECT_LT(s.max_speed, 1.0);
    EXPECT_LT(s.max_accel, 3.0);
    EXPECT_LT(s.max_angular_speed, 60.0 * kDeg);
    const Vector3d range = s.max_t - s.min_t;
    switch (motion) {
      case SynthMotion::kXyz:
        for (int a = 0; a < 3; ++a) {
          EXPECT_GT(range[a], 1.6 * synth::kXyzAmplitude[a]) << "axis " << a;
          EXPECT_LE(range[a], 2.0 * synth::kXyzAmplitude[a] + 1e-9) << "axis " << a;
        }
        EXPECT_LE(s.max_abs_ypr.maxCoeff(), synth::kXyzRotationDeg * kDeg + 1e-9);
        EXPECT_GT(s.max_abs_ypr.minCoeff(), 0.5 * synth::kXyzRotationDeg * kDeg);
        break;
      case SynthMotion::kRpy:
        for (int a = 0; a < 3; ++a) {
          EXPECT_GT(s.max_abs_ypr[a], 0.95 * synth::kRpyAmplitudeDeg * kDeg) << "angle " << a;
          EXPECT_LE(s.max_abs_ypr[a], synth::kRpyAmplitudeDeg * kDeg + 1e-9) << "angle " << a;
          EXPECT_LE(range[a], 2.0 * synth::kRpyTranslation + 1e-9);
        }
        break;
      case SynthMotion::kHalfsphere: {
        const Vector3d centre = synth::HalfsphereCentre();
        const Vector3d pole = (synth::CameraHome() - synth::LookTarget()).normalized();
        double min_polar = 1e9, max_polar = 0.0;
        for (const Rigid3d& p : traj.world_from_cam) {
          const Vector3d d = p.translation - centre;
          ASSERT_NEAR(d.norm(), synth::kHalfsphereRadius, 1e-9);
          const double polar = std::acos(std::clamp(d.normalized().dot(pole), -1.0, 1.0));
          min_polar = std::min(min_polar, polar);
          max_polar = std::max(max_polar, polar);
          // Looks at the target.
          const Vector3d forward = p.rotation * Vector3d::UnitZ();
          ASSERT_GT(forward.dot((synth::LookTarget() - p.translation).normalized()), 1.0 - 1e-9);
          // x axis horizontal (no roll).
          ASSERT_NEAR((p.rotation * Vector3d::UnitX()).z(), 0.0, 1e-9);
        }
        EXPECT_LE(max_polar, synth::kHalfsphereMaxPolarDeg * kDeg + 1e-9);
        EXPECT_GT(max_polar - min_polar, 30.0 * kDeg);
        EXPECT_GT(range.norm(), 0.8);
        break;
      }
      case SynthMotion::kLoop: {
        // On the circle, looking outwards, x axis horizontal; 10 s of a 12 s
        // lap; one lap later the pose is the same (the loop closes).
        for (const Rigid3d& p : traj.world_from_cam) {
          const Vector3d d = p.translation - synth::LoopCentre();
          ASSERT_NEAR(d.norm(), synth::kLoopRadius, 1e-9);
          ASSERT_NEAR(d.z(), 0.0, 1e-9);
          const Vector3d forward = p.rotation * Vector3d::UnitZ();
          ASSERT_NEAR(forward.head<2>().normalized().dot(d.head<2>().normalized()), 1.0, 1e-9);
          ASSERT_NEAR((p.rotation * Vector3d::UnitX()).z(), 0.0, 1e-9);
        }
        const Rigid3d a = synth::SynthCameraPose(motion, 1.0, o.seed);
        const Rigid3d b = synth::SynthCameraPose(motion, 1.0 + synth::kLoopPeriod, o.seed);
        EXPECT_LT((a.translation - b.translation).norm(), 1e-9);
        EXPECT_LT(a.rotation.angularDistance(b.rotation), 1e-9);
        EXPECT_GT(range.head<2>().minCoeff(), 1.5 * synth::kLoopRadius);
        break;
      }
      case SynthMotion::kStatic:
        EXPECT_LE(range.maxCoeff(), 2.0 * synth::kStaticJitter + 1e-9);
        EXPECT_GT(range.maxCoeff(), 0.0);
        EXPECT_LE(s.max_abs_ypr.maxCoeff(), synth::kStaticJitterDeg * kDeg + 1e-9);
        break;
    }
    // The camera stays inside the room, away from the walls.
    for (const Rigid3d& p : traj.world_from_cam) {
      ASSERT_GT(p.translation.z(), 0.3);
      ASSERT_LT(p.translation.z(), synth::kRoomHeight - 0.2);
    }
  }
}

TEST(SynthTrajectoryTest, SeedChangesPhases) {
  const Trajectory a = MakeSynthTrajectory(SmallOptions(1, 1, SynthMotion::kXyz, 5));
  const Trajectory b = MakeSynthTrajectory(SmallOptions(2, 1, SynthMotion::kXyz, 5));
  EXPECT_GT((a.world_from_cam[0].translation - b.world_from_cam[0].translation).norm(), 1e-3);
}

// ---------------------------------------------------------------------------
// Depth noise

TEST(KinectNoiseTest, AxialNoiseMatchesTheModelAtKnownDepths) {
  Camera camera = SynthOptions().MakeCamera();
  camera.width = camera.height = 200;
  synth::KinectNoiseParams params;
  params.dropout = 0.0;
  for (double z : {1.0, 2.0, 4.0}) {
    const ImageF depth(200, 200, 1, static_cast<float>(z));
    const ImageF cos_incidence(200, 200, 1, 1.0f);
    const ImageF noisy = synth::ApplyKinectNoise(depth, cos_incidence, camera, params, 42, 0);
    double sum = 0.0, sum2 = 0.0;
    int n = 0;
    for (float v : noisy.pixels()) {
      ASSERT_GT(v, 0.0f);
      // Quantised to 1/5000 m.
      ASSERT_NEAR(v * 5000.0, std::round(v * 5000.0), 2e-3 * z);
      sum += v - z;
      sum2 += (v - z) * (v - z);
      ++n;
    }
    const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
    const double sigma = 0.0012 + 0.0019 * (z - 0.4) * (z - 0.4);
    EXPECT_DOUBLE_EQ(synth::KinectAxialSigma(z, 0.0), sigma);
    EXPECT_NEAR(sd, sigma, 0.03 * sigma) << "z = " << z;
    EXPECT_NEAR(mean, 0.0, 4.0 * sigma / std::sqrt(n) + 1e-4) << "z = " << z;
  }
  // Beyond 60 degrees the angle term adds to the noise.
  EXPECT_GT(synth::KinectAxialSigma(2.0, 70 * kDeg), synth::KinectAxialSigma(2.0, 50 * kDeg));
  EXPECT_EQ(synth::KinectAxialSigma(2.0, 50 * kDeg), synth::KinectAxialSigma(2.0, 0.0));
}

TEST(KinectNoiseTest, HolesAtRangeLimitsGrazingAnglesDropoutAndEdges) {
  Camera camera = SynthOptions().MakeCamera();
  synth::KinectNoiseParams params;
  params.dropout = 0.0;
  auto hole_fraction = [](const ImageF& img) {
    return static_cast<double>(std::count(img.pixels().begin(), img.pixels().end(), 0.0f)) / img.size();
  };
  const ImageF facing(100, 100, 1, 1.0f);
  EXPECT_EQ(hole_fraction(synth::ApplyKinectNoise(ImageF(100, 100, 1, 0.2f), facing, camera, params, 1, 0)),
            1.0);
  EXPECT_EQ(hole_fraction(synth::ApplyKinectNoise(ImageF(100, 100, 1, 9.0f), facing, camera, params, 1, 0)),
            1.0);
  EXPECT_EQ(hole_fraction(synth::ApplyKinectNoise(ImageF(100, 100, 1, 2.0f), facing, camera, params, 1, 0)),
            0.0);
  const ImageF grazing(100, 100, 1, static_cast<float>(std::cos(86 * kDeg)));
  EXPECT_EQ(hole_fraction(synth::ApplyKinectNoise(ImageF(100, 100, 1, 2.0f), grazing, camera, params, 1, 0)),
            1.0);
  params.dropout = 0.1;
  EXPECT_NEAR(hole_fraction(synth::ApplyKinectNoise(ImageF(100, 100, 1, 2.0f), facing, camera, params, 1, 0)),
              0.1, 0.015);
  // A step edge: left half at 1 m, right half at 3 m. The far side next to
  // the edge loses most pixels, the rest almost none.
  params.dropout = 0.0;
  ImageF step(100, 100, 1, 3.0f);
  for (int y = 0; y < 100; ++y) {
    for (int x = 0; x < 50; ++x) step.at(x, y) = 1.0f;
  }
  const ImageF noisy = synth::ApplyKinectNoise(step, facing, camera, params, 1, 0);
  auto column_holes = [&](int x) {
    int holes = 0;
    for (int y = 0; y < 100; ++y) holes += noisy.at(x, y) == 0.0f;
    return holes / 100.0;
  };
  EXPECT_GT(column_holes(50), 0.5);
  EXPECT_LT(column_holes(10), 0.01);
  EXPECT_LT(column_holes(90), 0.01);
  // Deterministic per (seed, frame); another frame differs.
  const ImageF again = synth::ApplyKinectNoise(step, facing, camera, params, 1, 0);
  EXPECT_EQ(noisy.pixels(), again.pixels());
  const ImageF other = synth::ApplyKinectNoise(step, facing, camera, params, 1, 1);
  EXPECT_NE(noisy.pixels(), other.pixels());
}

TEST(KinectNoiseTest, SceneSensorDepthStaysCloseToExactDepth) {
  const SyntheticScene scene(SmallOptions(9, 2, SynthMotion::kXyz, 3));
  const SynthFrame frame = scene.Render(1);
  int valid = 0, far_off = 0;
  for (int y = 0; y < frame.depth.height(); ++y) {
    for (int x = 0; x < frame.depth.width(); ++x) {
      const double z = frame.depth.at(x, y), n = frame.depth_noisy.at(x, y);
      if (n == 0.0) continue;
      ++valid;
      // Off by more than 6 sigma only where lateral noise read a neighbour.
      far_off += std::abs(n - z) > 6.0 * synth::KinectAxialSigma(z, 80 * kDeg) + 2e-4;
    }
  }
  const double pixels = frame.depth.size();
  EXPECT_GT(valid / pixels, 0.8);
  EXPECT_LT(valid / pixels, 1.0);
  EXPECT_LT(far_off / pixels, 0.03);
  // Without noise the sensor depth is the exact depth.
  SynthOptions o = SmallOptions(9, 2, SynthMotion::kXyz, 3);
  o.depth_noise = false;
  const SyntheticScene clean(o);
  const SynthFrame f = clean.Render(1);
  EXPECT_EQ(f.depth.pixels(), f.depth_noisy.pixels());
  EXPECT_EQ(f.depth.pixels(), frame.depth.pixels());
}

// ---------------------------------------------------------------------------
// Written sequences

TEST(SynthSequenceTest, SameSeedSameBytesDifferentSeedDiffers) {
  const std::string root = testing::TestTempDir();
  const SynthOptions o = SmallOptions(5, 2, SynthMotion::kHalfsphere, 5);
  WriteSyntheticSequence(o, root + "/a");
  WriteSyntheticSequence(o, root + "/b");
  SynthOptions other = o;
  other.seed = 6;
  WriteSyntheticSequence(other, root + "/c");
  int files = 0;
  bool any_rgb_differs = false, any_depth_differs = false;
  for (const auto& entry : fs::recursive_directory_iterator(root + "/a")) {
    if (!entry.is_regular_file()) continue;
    const std::string rel = fs::relative(entry.path(), root + "/a").string();
    ASSERT_EQ(FileBytes(root + "/a/" + rel), FileBytes(root + "/b/" + rel)) << rel;
    ++files;
    if (rel.rfind("rgb/", 0) == 0)
      any_rgb_differs |= FileBytes(root + "/a/" + rel) != FileBytes(root + "/c/" + rel);
    if (rel.rfind("depth/", 0) == 0) {
      any_depth_differs |= FileBytes(root + "/a/" + rel) != FileBytes(root + "/c/" + rel);
    }
  }
  EXPECT_EQ(files, 5 * 3 + 6);
  EXPECT_TRUE(any_rgb_differs);
  EXPECT_TRUE(any_depth_differs);
}

TEST(SynthSequenceTest, WrittenFolderHasTheTumLayout) {
  const std::string dir = testing::TestTempDir() + "/seq";
  SynthOptions o = SmallOptions(4, 2, SynthMotion::kXyz, 8);
  const SynthSequenceSummary summary = WriteSyntheticSequence(o, dir);
  EXPECT_EQ(summary.frames, 8);
  EXPECT_LE(summary.max_coverage, o.max_coverage);

  const auto rgb = ReadList(dir + "/rgb.txt");
  const auto depth = ReadList(dir + "/depth.txt");
  const auto assoc = ReadList(dir + "/associations.txt");
  ASSERT_EQ(rgb.size(), 8u);
  ASSERT_EQ(depth.size(), 8u);
  ASSERT_EQ(assoc.size(), 8u);
  const Trajectory gt = ReadTumTrajectory(dir + "/groundtruth.txt");
  ASSERT_EQ(gt.size(), 8u);
  const SyntheticScene scene(o);
  for (int i = 0; i < 8; ++i) {
    ASSERT_EQ(rgb[i].size(), 2u);
    ASSERT_EQ(assoc[i].size(), 4u);
    EXPECT_EQ(assoc[i][0], rgb[i][0]);
    EXPECT_EQ(assoc[i][1], rgb[i][1]);
    EXPECT_EQ(assoc[i][2], depth[i][0]);
    EXPECT_EQ(assoc[i][3], depth[i][1]);
    EXPECT_EQ(std::stod(rgb[i][0]), gt.timestamps[i]);
    EXPECT_EQ(rgb[i][1], "rgb/" + rgb[i][0] + ".png");
    const std::string name = fs::path(rgb[i][1]).filename().string();
    ASSERT_TRUE(fs::exists(dir + "/" + rgb[i][1])) << rgb[i][1];
    ASSERT_TRUE(fs::exists(dir + "/" + depth[i][1])) << depth[i][1];
    ASSERT_TRUE(fs::exists(dir + "/masks/" + name)) << name;
    // The files hold what Render gives (written from a parallel loop, read
    // back here: thread count and order do not matter).
    const SynthFrame frame = scene.Render(i);
    EXPECT_EQ(ReadRgb8(dir + "/" + rgb[i][1]).pixels(), frame.rgb.pixels());
    EXPECT_EQ(ReadGray8(dir + "/masks/" + name).pixels(), frame.mask.pixels());
    EXPECT_EQ(ReadDepth16(dir + "/" + depth[i][1]).pixels(), DepthToU16(frame.depth_noisy, 5000.0).pixels());
    EXPECT_LT((gt.world_from_cam[i].translation - frame.world_from_cam.translation).norm(), 1e-8);
    EXPECT_LT(RotationAngle(gt.world_from_cam[i].rotation, frame.world_from_cam.rotation), 1e-6);
  }
  // camera.yaml
  std::map<std::string, std::string> yaml;
  std::istringstream in(ReadTextFile(dir + "/camera.yaml"));
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    const size_t colon = line.find(':');
    ASSERT_NE(colon, std::string::npos) << line;
    yaml[line.substr(0, colon)] = line.substr(colon + 2);
  }
  EXPECT_EQ(yaml["fx"], "131.25");
  EXPECT_EQ(yaml["fy"], "131.25");
  EXPECT_EQ(yaml["cx"], "79.5");
  EXPECT_EQ(yaml["cy"], "59.5");
  EXPECT_EQ(yaml["width"], "160");
  EXPECT_EQ(yaml["height"], "120");
  EXPECT_EQ(yaml["depth_factor"], "5000");
  EXPECT_EQ(yaml["distortion"], "[0, 0, 0, 0, 0]");
  // No temporary files are left behind.
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    EXPECT_EQ(entry.path().string().find(".tmp."), std::string::npos) << entry.path();
  }
}

TEST(SynthSequenceTest, DatasetReaderOpensTheSequence) {
  const std::string dir = testing::TestTempDir() + "/synthetic";
  const SynthOptions o = SmallOptions(12, 1, SynthMotion::kStatic, 4);
  WriteSyntheticSequence(o, dir);
  const std::unique_ptr<Dataset> dataset = OpenDataset(dir);
  ASSERT_EQ(dataset->size(), 4u);
  EXPECT_EQ(dataset->frames_with_depth(), 4u);
  EXPECT_EQ(dataset->frames_with_mask(), 4u);
  EXPECT_TRUE(dataset->has_ground_truth());
  EXPECT_EQ(dataset->camera().fx, 131.25);
  EXPECT_EQ(dataset->camera().width, 160);
  EXPECT_EQ(dataset->depth_factor(), 5000.0);
  const Frame frame = dataset->Load(2);
  const SyntheticScene scene(o);
  const SynthFrame expected = scene.Render(2);
  EXPECT_EQ(frame.rgb.pixels(), expected.rgb.pixels());
  EXPECT_EQ(frame.dynamic_mask.pixels(), expected.mask.pixels());
  ASSERT_TRUE(frame.world_from_cam_gt.has_value());
  EXPECT_LT((frame.world_from_cam_gt->translation - expected.world_from_cam.translation).norm(), 1e-6);
}

}  // namespace
}  // namespace dypho
