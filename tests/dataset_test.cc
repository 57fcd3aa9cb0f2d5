// Dataset readers: TUM layout on the shared real sequences, camera presets
// and camera files, RGB-depth association, ground-truth interpolation,
// masks, and every kind of bad input (each error names the file and line).
#include "engine/dataset/dataset.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "common/check.h"
#include "engine/dataset/camera_file.h"
#include "engine/dataset/dataset_info.h"
#include "engine/eval/trajectory.h"
#include "engine/io/image_io.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;
using ::dypho::testing::SharedData;
using ::dypho::testing::TestTempDir;

void WriteText(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream out(path);
  out << text;
}

// Expects `f` to throw InvalidInput whose message contains every string of `parts`.
void ExpectInvalid(const std::function<void()>& f, const std::vector<std::string>& parts) {
  try {
    f();
    ADD_FAILURE() << "expected InvalidInput mentioning '" << parts.front() << "'";
  } catch (const InvalidInput& e) {
    const std::string message = e.what();
    for (const std::string& part : parts) {
      EXPECT_NE(message.find(part), std::string::npos) << "message lacks '" << part << "': " << message;
    }
  }
}

ImageU8 SolidRgb(int w, int h, uint8_t value) { return ImageU8(w, h, 3, value); }

Image<uint16_t> SolidDepth(int w, int h, uint16_t value) { return Image<uint16_t>(w, h, 1, value); }

// A small generic dataset: `n` frames 32x24 at 10 Hz, a camera.yaml, rgb.txt,
// depth.txt (depth 2 ms after each RGB frame), nothing else.
struct SmallDataset {
  std::string folder;
  int n = 4;
  int width = 32;
  int height = 24;

  explicit SmallDataset(const std::string& dir, int frames = 4) : folder(dir), n(frames) {
    fs::create_directories(folder);
    Camera c;
    c.fx = c.fy = 30.0;
    c.cx = 15.5;
    c.cy = 11.5;
    c.width = width;
    c.height = height;
    WriteText(folder + "/camera.yaml", FormatCameraYaml(c, 5000.0));
    std::string rgb = "# color images\n# timestamp filename\n", depth = "# depth maps\n";
    for (int i = 0; i < n; ++i) {
      const std::string rgb_name = "rgb/" + Stamp(RgbTime(i)) + ".png";
      const std::string depth_name = "depth/" + Stamp(DepthTime(i)) + ".png";
      WriteRgb8(folder + "/" + rgb_name, SolidRgb(width, height, static_cast<uint8_t>(10 * i)));
      WriteDepth16(folder + "/" + depth_name,
                   SolidDepth(width, height, static_cast<uint16_t>(5000 + 1000 * i)));
      rgb += Stamp(RgbTime(i)) + " " + rgb_name + "\n";
      depth += Stamp(DepthTime(i)) + " " + depth_name + "\n";
    }
    WriteText(folder + "/rgb.txt", rgb);
    WriteText(folder + "/depth.txt", depth);
  }
  static double RgbTime(int i) { return 100.0 + 0.1 * i; }
  static double DepthTime(int i) { return 100.0 + 0.1 * i + 0.002; }
  static std::string Stamp(double t) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.6f", t);
    return buf;
  }
};

// ---------------------------------------------------------------------------
// Real data

TEST(DatasetTest, ReadsTumFr1RpyHead250) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  const auto dataset = OpenDataset(SharedData("tum_fr1_rpy_head250"));
  ASSERT_EQ(dataset->size(), 250u);
  EXPECT_EQ(dataset->format(), "tum");
  EXPECT_EQ(dataset->name(), "tum_fr1_rpy_head250");
  EXPECT_DOUBLE_EQ(dataset->depth_factor(), 5000.0);
  // The folder name has "fr1": the freiburg1 preset with its distortion.
  const Camera& c = dataset->camera();
  EXPECT_DOUBLE_EQ(c.fx, 517.3);
  EXPECT_DOUBLE_EQ(c.fy, 516.5);
  EXPECT_DOUBLE_EQ(c.cx, 318.6);
  EXPECT_DOUBLE_EQ(c.cy, 255.3);
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  const std::array<double, 5> fr1_distortion{0.2624, -0.9531, -0.0054, 0.0026, 1.1633};
  EXPECT_EQ(c.distortion, fr1_distortion);
  EXPECT_NE(dataset->camera_source().find("freiburg1"), std::string::npos);

  EXPECT_EQ(dataset->frames_with_depth(), 250u);
  EXPECT_TRUE(dataset->has_ground_truth());
  EXPECT_TRUE(dataset->frames_without_gt().empty());
  EXPECT_EQ(dataset->frames_with_mask(), 0u);

  const FrameInfo& first = dataset->frames().front();
  EXPECT_DOUBLE_EQ(first.timestamp, 1305031229.528748);
  EXPECT_NEAR(first.depth_listed_timestamp, 1305031229.528784, 1e-6);
  // fr1's Kinect captures depth 20 ms before its colour image (camera_file.h).
  EXPECT_NEAR(first.depth_timestamp, first.timestamp - 0.020, 1e-9);
  EXPECT_NE(dataset->depth_time_source().find("-0.020 s (preset freiburg1)"), std::string::npos);
  EXPECT_EQ(fs::path(first.rgb_path).filename(), "1305031229.528748.png");
  EXPECT_EQ(fs::path(first.depth_path).filename(), "1305031229.528784.png");
  EXPECT_EQ(fs::path(dataset->frames().back().rgb_path).filename(), "1305031237.829769.png");
  for (size_t i = 1; i < dataset->size(); ++i) {
    ASSERT_GT(dataset->frames()[i].timestamp, dataset->frames()[i - 1].timestamp);
  }

  // Ground truth at frame 0 lies between its two neighbouring samples
  // (groundtruth.txt lines at 1305031229.5231 and 1305031229.5331 or so).
  const Trajectory& gt = dataset->ground_truth();
  const size_t k =
      std::upper_bound(gt.timestamps.begin(), gt.timestamps.end(), first.timestamp) - gt.timestamps.begin();
  ASSERT_GT(k, 0u);
  ASSERT_LT(k, gt.size());
  const double t = (first.timestamp - gt.timestamps[k - 1]) / (gt.timestamps[k] - gt.timestamps[k - 1]);
  const Eigen::Vector3d expected =
      (1 - t) * gt.world_from_cam[k - 1].translation + t * gt.world_from_cam[k].translation;
  ASSERT_TRUE(first.world_from_cam_gt.has_value());
  EXPECT_NEAR((first.world_from_cam_gt->translation - expected).norm(), 0.0, 1e-12);

  const Frame frame = dataset->Load(0);
  EXPECT_EQ(frame.rgb.width(), 640);
  EXPECT_EQ(frame.rgb.height(), 480);
  EXPECT_EQ(frame.rgb.channels(), 3);
  ASSERT_TRUE(frame.has_depth);
  EXPECT_EQ(frame.depth.width(), 640);
  EXPECT_EQ(frame.depth.channels(), 1);
  EXPECT_TRUE(frame.dynamic_mask.empty());
  // Depth is the 16-bit value / 5000.
  const Image<uint16_t> raw = ReadDepth16(first.depth_path);
  size_t valid = 0;
  for (size_t i = 0; i < raw.size(); ++i) {
    ASSERT_FLOAT_EQ(frame.depth.data()[i], static_cast<float>(raw.data()[i] / 5000.0));
    if (raw.data()[i] > 0) ++valid;
  }
  EXPECT_GT(valid, raw.size() / 2);
  ASSERT_TRUE(frame.world_from_cam_gt.has_value());
  EXPECT_NEAR((frame.world_from_cam_gt->translation - expected).norm(), 0.0, 1e-12);
}

TEST(DatasetTest, ReadsTumFr3WalkingXyz3Frames) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr3_walking_xyz_3frames");
  const auto dataset = OpenDataset(SharedData("tum_fr3_walking_xyz_3frames"));
  ASSERT_EQ(dataset->size(), 3u);
  EXPECT_EQ(dataset->format(), "tum");
  EXPECT_DOUBLE_EQ(dataset->camera().fx, 535.4);
  EXPECT_DOUBLE_EQ(dataset->camera().fy, 539.2);
  EXPECT_DOUBLE_EQ(dataset->camera().cx, 320.1);
  EXPECT_DOUBLE_EQ(dataset->camera().cy, 247.6);
  EXPECT_FALSE(dataset->camera().HasDistortion());
  // Frames from rgb/ (there is no rgb.txt), depth from associations.txt: the
  // third RGB frame has none.
  EXPECT_TRUE(dataset->info(0).has_depth);
  EXPECT_TRUE(dataset->info(1).has_depth);
  EXPECT_FALSE(dataset->info(2).has_depth);
  EXPECT_DOUBLE_EQ(dataset->info(2).timestamp, 1341846325.417931);
  EXPECT_EQ(fs::path(dataset->info(1).depth_path).filename(), "1341846316.570146.png");
  EXPECT_EQ(dataset->frames_with_depth(), 2u);
  // No ground truth: every frame is reported without a pose.
  EXPECT_FALSE(dataset->has_ground_truth());
  EXPECT_EQ(dataset->frames_without_gt(), (std::vector<size_t>{0, 1, 2}));

  const Frame with_depth = dataset->Load(1);
  EXPECT_TRUE(with_depth.has_depth);
  EXPECT_EQ(with_depth.depth.width(), 640);
  EXPECT_FALSE(with_depth.world_from_cam_gt.has_value());
  const Frame without_depth = dataset->Load(2);
  EXPECT_FALSE(without_depth.has_depth);
  EXPECT_TRUE(without_depth.depth.empty());
  EXPECT_EQ(without_depth.rgb.width(), 640);
  EXPECT_EQ(without_depth.rgb.height(), 480);
}

TEST(DatasetTest, ExplicitPresetOverridesFolderName) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr3_walking_xyz_3frames");
  DatasetOptions options;
  options.camera_preset = "fr1";
  const auto dataset = OpenDataset(SharedData("tum_fr3_walking_xyz_3frames"), options);
  EXPECT_DOUBLE_EQ(dataset->camera().fx, 517.3);
  EXPECT_TRUE(dataset->camera().HasDistortion());
  options.camera_preset = "bonn";
  const auto bonn = OpenDataset(SharedData("tum_fr3_walking_xyz_3frames"), options);
  EXPECT_EQ(bonn->format(), "bonn");
  EXPECT_DOUBLE_EQ(bonn->camera().fx, 542.822841);
  EXPECT_DOUBLE_EQ(bonn->camera().distortion[0], 0.039903);
  options.camera_preset = "freiburg9";
  ExpectInvalid([&] { OpenDataset(SharedData("tum_fr3_walking_xyz_3frames"), options); }, {"freiburg9"});
}

// Without associations.txt, nearest-timestamp association (< 0.02 s, greedy)
// reproduces the pairing shipped in the TUM sequence's associations.txt.
TEST(DatasetTest, AssociatesByNearestTimestampLikeTumAssociations) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  const std::string source = SharedData("tum_fr1_rpy_head250");
  const std::string copy = TestTempDir() + "/tum_fr1_copy";
  fs::create_directories(copy);
  fs::copy_file(source + "/rgb.txt", copy + "/rgb.txt");
  fs::copy_file(source + "/depth.txt", copy + "/depth.txt");
  fs::create_directory_symlink(fs::absolute(source + "/rgb"), copy + "/rgb");
  fs::create_directory_symlink(fs::absolute(source + "/depth"), copy + "/depth");
  ASSERT_FALSE(fs::exists(copy + "/associations.txt"));

  const auto original = OpenDataset(source);
  const auto by_time = OpenDataset(copy);
  ASSERT_EQ(by_time->size(), original->size());
  EXPECT_DOUBLE_EQ(by_time->camera().fx, 517.3);  // "fr1" in the copy's name
  for (size_t i = 0; i < original->size(); ++i) {
    ASSERT_TRUE(by_time->info(i).has_depth) << "frame " << i;
    EXPECT_EQ(fs::path(by_time->info(i).depth_path).filename(),
              fs::path(original->info(i).depth_path).filename())
        << "frame " << i;
    EXPECT_NE(by_time->info(i).depth_source.find("depth.txt:"), std::string::npos);
  }
  EXPECT_FALSE(by_time->has_ground_truth());
}

TEST(DatasetTest, NearestTimestampAssociationIsGreedyAndBounded) {
  const std::string dir = TestTempDir() + "/generic";
  SmallDataset data(dir, 3);
  // RGB at 100.0, 100.1, 100.2. Depth: 100.004 and 100.006 compete for the
  // first frame (100.004 wins, 100.006 is then 0.094 from frame 1: no
  // match); frame 1 gets nothing; 100.2199 is 0.0199 from frame 2 (< 0.02).
  WriteDepth16(dir + "/depth/a.png", SolidDepth(32, 24, 5000));
  WriteDepth16(dir + "/depth/b.png", SolidDepth(32, 24, 5000));
  WriteDepth16(dir + "/depth/c.png", SolidDepth(32, 24, 5000));
  WriteText(dir + "/depth.txt", "100.006 depth/b.png\n100.004000 depth/a.png\n");
  ExpectInvalid([&] { OpenDataset(dir); }, {"depth.txt:2", "100.004"});  // unsorted
  WriteText(dir + "/depth.txt", "100.004 depth/a.png\n100.006 depth/b.png\n100.2199 depth/c.png\n");
  const auto dataset = OpenDataset(dir);
  ASSERT_EQ(dataset->size(), 3u);
  EXPECT_EQ(fs::path(dataset->info(0).depth_path).filename(), "a.png");
  EXPECT_FALSE(dataset->info(1).has_depth);
  EXPECT_EQ(fs::path(dataset->info(2).depth_path).filename(), "c.png");
  EXPECT_EQ(dataset->info(2).depth_source, dir + "/depth.txt:3");
  // Exactly max_depth_dt apart is not a match (strict, as associate.py);
  // 1/32 s keeps the arithmetic exact.
  DatasetOptions options;
  options.max_depth_dt = 0.03125;
  WriteText(dir + "/depth.txt", "100.03125 depth/a.png\n");
  EXPECT_FALSE(OpenDataset(dir, options)->info(0).has_depth);
  WriteText(dir + "/depth.txt", "100.03124 depth/a.png\n");
  EXPECT_TRUE(OpenDataset(dir, options)->info(0).has_depth);
  // A tighter bound from the options.
  WriteText(dir + "/depth.txt", "100.004 depth/a.png\n");
  options.max_depth_dt = 0.003;
  EXPECT_FALSE(OpenDataset(dir, options)->info(0).has_depth);
}

// ---------------------------------------------------------------------------
// Generic folders, camera files, masks, ground truth

TEST(DatasetTest, GenericFolderWithCameraFileMasksAndGroundTruth) {
  const std::string dir = TestTempDir() + "/synthetic_like";
  SmallDataset data(dir, 4);
  // Masks named like the RGB images; nonzero values become 255.
  for (int i = 0; i < 4; i += 2) {
    ImageU8 mask(32, 24, 1, 0);
    mask.at(3, 4) = 1;
    mask.at(5, 6) = 200;
    WriteGray8(dir + "/masks/" + SmallDataset::Stamp(SmallDataset::RgbTime(i)) + ".png", mask);
  }
  // Associations pair RGB i with depth i.
  std::string assoc;
  for (int i = 0; i < 4; ++i) {
    assoc += SmallDataset::Stamp(SmallDataset::RgbTime(i)) + " rgb/" +
             SmallDataset::Stamp(SmallDataset::RgbTime(i)) + ".png " +
             SmallDataset::Stamp(SmallDataset::DepthTime(i)) + " depth/" +
             SmallDataset::Stamp(SmallDataset::DepthTime(i)) + ".png\n";
  }
  WriteText(dir + "/associations.txt", assoc);
  // Ground truth covers frames 1 and 2 only (100.05 .. 100.25): frames 0 and
  // 3 (100.0, 100.3) are outside and must be reported.
  WriteText(dir + "/groundtruth.txt",
            "# timestamp tx ty tz qx qy qz qw\n"
            "100.05 0 0 0 0 0 0 1\n"
            "100.15 1 2 3 0 0 0.7071067811865476 0.7071067811865476\n"
            "100.25 1 2 3 0 0 0.7071067811865476 0.7071067811865476\n");
  const auto dataset = OpenDataset(dir);
  EXPECT_EQ(dataset->format(), "generic");
  EXPECT_EQ(dataset->camera().width, 32);
  EXPECT_DOUBLE_EQ(dataset->camera().fx, 30.0);
  EXPECT_NE(dataset->camera_source().find("camera.yaml"), std::string::npos);
  EXPECT_EQ(dataset->frames_with_mask(), 2u);
  EXPECT_EQ(dataset->frames_without_gt(), (std::vector<size_t>{0, 3}));
  EXPECT_FALSE(dataset->info(0).world_from_cam_gt.has_value());
  // Frame 1 at 100.1: midway between the first two samples.
  const auto& pose = dataset->info(1).world_from_cam_gt;
  ASSERT_TRUE(pose.has_value());
  EXPECT_NEAR((pose->translation - Eigen::Vector3d(0.5, 1.0, 1.5)).norm(), 0.0, 1e-9);
  EXPECT_NEAR(pose->rotation.angularDistance(
                  Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()))),
              0.0, 1e-9);

  const Frame f0 = dataset->Load(0);
  ASSERT_FALSE(f0.dynamic_mask.empty());
  EXPECT_EQ(f0.dynamic_mask.at(3, 4), 255);
  EXPECT_EQ(f0.dynamic_mask.at(5, 6), 255);
  EXPECT_EQ(f0.dynamic_mask.at(0, 0), 0);
  EXPECT_FLOAT_EQ(f0.depth.at(0, 0), 1.0f);  // 5000 / 5000
  EXPECT_TRUE(dataset->Load(1).dynamic_mask.empty());
  EXPECT_FLOAT_EQ(dataset->Load(3).depth.at(7, 7), 1.6f);  // 8000 / 5000
  EXPECT_EQ(dataset->Load(2).rgb.at(1, 1, 0), 20);

  const DatasetScan scan = ScanDataset(*dataset, /*show_progress=*/false);
  EXPECT_EQ(scan.frames_loaded, 4u);
  EXPECT_EQ(scan.depth_frames, 4u);
  EXPECT_DOUBLE_EQ(scan.mean_valid_depth, 1.0);
  EXPECT_NEAR(scan.min_depth, 1.0, 1e-6);
  EXPECT_NEAR(scan.max_depth, 1.6, 1e-6);
  EXPECT_EQ(scan.mask_frames, 2u);
  EXPECT_NEAR(scan.mean_dynamic_fraction, 2.0 / (32 * 24), 1e-12);
  const std::string text = DescribeDataset(*dataset, &scan);
  EXPECT_NE(text.find("without ground truth: frames 0, 3"), std::string::npos) << text;
}

TEST(DatasetTest, GroundTruthGapIsNotInterpolated) {
  const std::string dir = TestTempDir() + "/gap";
  SmallDataset data(dir, 3);
  WriteText(dir + "/groundtruth.txt", "99.9 0 0 0 0 0 0 1\n100.05 0 0 0 0 0 0 1\n100.9 0 0 0 0 0 0 1\n");
  DatasetOptions options;
  options.max_gt_gap = 0.5;
  const auto dataset = OpenDataset(dir, options);
  EXPECT_EQ(dataset->frames_without_gt(), (std::vector<size_t>{1, 2}));  // inside the 0.85 s gap
  options.max_gt_gap = 1.0;
  EXPECT_TRUE(OpenDataset(dir, options)->frames_without_gt().empty());
}

TEST(DatasetTest, InterpolatesPoseAtMidpoint) {
  Trajectory gt;
  gt.Add(10.0, Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0)));
  gt.Add(12.0, Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX())),
                       Eigen::Vector3d(2, -4, 6)));
  const auto mid = InterpolatePose(gt, 11.0, 5.0);
  ASSERT_TRUE(mid.has_value());
  EXPECT_NEAR((mid->translation - Eigen::Vector3d(1, -2, 3)).norm(), 0.0, 1e-12);
  const Eigen::AngleAxisd half(mid->rotation);
  EXPECT_NEAR(half.angle(), 0.5, 1e-12);
  EXPECT_NEAR((half.axis() - Eigen::Vector3d::UnitX()).norm(), 0.0, 1e-12);
  const auto quarter = InterpolatePose(gt, 10.5, 5.0);
  ASSERT_TRUE(quarter.has_value());
  EXPECT_NEAR((quarter->translation - Eigen::Vector3d(0.5, -1, 1.5)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(Eigen::AngleAxisd(quarter->rotation).angle(), 0.25, 1e-12);
  // Ends are included, outside is not, a gap wider than max_gap is not.
  EXPECT_TRUE(InterpolatePose(gt, 10.0, 5.0).has_value());
  EXPECT_TRUE(InterpolatePose(gt, 12.0, 5.0).has_value());
  EXPECT_FALSE(InterpolatePose(gt, 9.999, 5.0).has_value());
  EXPECT_FALSE(InterpolatePose(gt, 12.001, 5.0).has_value());
  EXPECT_FALSE(InterpolatePose(gt, 11.0, 1.0).has_value());
}

TEST(DatasetTest, FolderWithoutListsPairsImagesByName) {
  const std::string dir = TestTempDir() + "/my_recording";
  for (int i = 0; i < 3; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.png", i);
    WriteRgb8(dir + "/rgb/" + name, SolidRgb(16, 12, 0));
    if (i != 1) WriteDepth16(dir + "/depth/" + name, SolidDepth(16, 12, 1000));
  }
  WriteText(dir + "/camera.json",
            R"({"fx": 20, "fy": 21, "cx": 7.5, "cy": 5.5, "width": 16, "height": 12,
                "distortion": [0.1, -0.2, 0.001, 0.002], "depth_factor": 1000})");
  DatasetOptions options;
  options.frame_rate = 20.0;
  const auto dataset = OpenDataset(dir, options);
  ASSERT_EQ(dataset->size(), 3u);
  EXPECT_DOUBLE_EQ(dataset->info(2).timestamp, 0.1);
  EXPECT_TRUE(dataset->info(0).has_depth);
  EXPECT_FALSE(dataset->info(1).has_depth);
  EXPECT_TRUE(dataset->info(2).has_depth);
  EXPECT_DOUBLE_EQ(dataset->depth_factor(), 1000.0);
  EXPECT_DOUBLE_EQ(dataset->camera().fy, 21.0);
  EXPECT_DOUBLE_EQ(dataset->camera().distortion[3], 0.002);
  EXPECT_DOUBLE_EQ(dataset->camera().distortion[4], 0.0);
  EXPECT_FLOAT_EQ(dataset->Load(2).depth.at(3, 3), 1.0f);
  // An explicit depth factor wins over the camera file.
  options.depth_factor = 500.0;
  EXPECT_FLOAT_EQ(OpenDataset(dir, options)->Load(0).depth.at(3, 3), 2.0f);
}

TEST(DatasetTest, CameraFileRoundTripsAndReportsBadKeys) {
  const std::string dir = TestTempDir();
  Camera c = *CameraPreset("freiburg1");
  WriteText(dir + "/cam.yaml", FormatCameraYaml(c, 5000.0));
  const CameraFile read = ReadCameraFile(dir + "/cam.yaml");
  EXPECT_DOUBLE_EQ(read.camera.fx, c.fx);
  EXPECT_DOUBLE_EQ(read.camera.cy, c.cy);
  EXPECT_EQ(read.camera.distortion, c.distortion);
  EXPECT_EQ(read.camera.width, 640);
  ASSERT_TRUE(read.depth_factor.has_value());
  EXPECT_DOUBLE_EQ(*read.depth_factor, 5000.0);

  WriteText(dir + "/missing.yaml", "fx: 500\nfy: 500\ncx: 320\ncy: 240\nwidth: 640\n");
  ExpectInvalid([&] { ReadCameraFile(dir + "/missing.yaml"); }, {"missing.yaml", "height"});
  WriteText(dir + "/bad.yaml", "fx: 500\nfy: five hundred\ncx: 320\ncy: 240\nwidth: 640\nheight: 480\n");
  ExpectInvalid([&] { ReadCameraFile(dir + "/bad.yaml"); }, {"bad.yaml:2", "fy"});
  WriteText(dir + "/neg.json", R"({"fx": -5, "fy": 500, "cx": 320, "cy": 240, "width": 640, "height": 480})");
  ExpectInvalid([&] { ReadCameraFile(dir + "/neg.json"); }, {"neg.json", "fx"});
  WriteText(dir + "/dist.json",
            R"({"fx": 5, "fy": 5, "cx": 3, "cy": 2, "width": 6, "height": 4, "distortion": [1, 2]})");
  ExpectInvalid([&] { ReadCameraFile(dir + "/dist.json"); }, {"dist.json", "distortion"});
  WriteText(dir + "/syntax.json", "{\"fx\": 5,");
  ExpectInvalid([&] { ReadCameraFile(dir + "/syntax.json"); }, {"syntax.json"});
}

TEST(DatasetTest, PresetFromFolderName) {
  EXPECT_EQ(PresetFromFolderName("/data/rgbd_dataset_freiburg1_rpy"), "freiburg1");
  EXPECT_EQ(PresetFromFolderName("/data/tum_fr1_rpy_head250/"), "freiburg1");
  EXPECT_EQ(PresetFromFolderName("rgbd_dataset_freiburg2_desk"), "freiburg2");
  EXPECT_EQ(PresetFromFolderName("/x/tum_fr3_walking_xyz_3frames"), "freiburg3");
  EXPECT_EQ(PresetFromFolderName("/x/rgbd_bonn_balloon"), "bonn");
  EXPECT_EQ(PresetFromFolderName("/fr1/my_recording"), "");  // only the folder's own name counts
  ExpectInvalid([] { PresetFromFolderName("/x/fr1_vs_fr3"); }, {"fr1_vs_fr3", "freiburg1", "freiburg3"});
}

// ---------------------------------------------------------------------------
// Bad input: every error names the file (and the list line).

TEST(DatasetTest, MissingFolder) {
  const std::string dir = TestTempDir() + "/no_such_dataset";
  ExpectInvalid([&] { OpenDataset(dir); }, {"does not exist", "no_such_dataset"});
}

TEST(DatasetTest, FolderWithoutImages) {
  const std::string dir = TestTempDir();
  ExpectInvalid([&] { OpenDataset(dir); }, {"not an RGB-D dataset folder", dir});
}

TEST(DatasetTest, NoCameraInformation) {
  const std::string dir = TestTempDir() + "/plain";
  SmallDataset data(dir, 2);
  fs::remove(dir + "/camera.yaml");
  ExpectInvalid([&] { OpenDataset(dir); }, {"cannot tell the camera", "plain"});
}

TEST(DatasetTest, ListedImageDoesNotExist) {
  const std::string dir = TestTempDir() + "/missing_image";
  SmallDataset data(dir, 3);
  fs::remove(dir + "/rgb/" + SmallDataset::Stamp(SmallDataset::RgbTime(1)) + ".png");
  ExpectInvalid([&] { OpenDataset(dir); }, {"rgb.txt:4", "100.100000.png", "does not exist"});
  SmallDataset again(dir, 3);
  fs::remove(dir + "/depth/" + SmallDataset::Stamp(SmallDataset::DepthTime(2)) + ".png");
  ExpectInvalid([&] { OpenDataset(dir); }, {"depth.txt:4", "100.202000.png", "does not exist"});
}

TEST(DatasetTest, ListedImageDoesNotDecode) {
  const std::string dir = TestTempDir() + "/corrupt";
  SmallDataset data(dir, 3);
  const std::string bad = dir + "/rgb/" + SmallDataset::Stamp(SmallDataset::RgbTime(2)) + ".png";
  WriteText(bad, "this is not a PNG file");
  const auto dataset = OpenDataset(dir);
  EXPECT_NO_THROW(dataset->Load(0));
  ExpectInvalid([&] { dataset->Load(2); }, {"100.200000.png", "does not decode", "rgb.txt:5"});
}

TEST(DatasetTest, EightBitDepth) {
  const std::string dir = TestTempDir() + "/depth8";
  SmallDataset data(dir, 2);
  const std::string depth = dir + "/depth/" + SmallDataset::Stamp(SmallDataset::DepthTime(1)) + ".png";
  WriteGray8(depth, ImageU8(32, 24, 1, 7));
  const auto dataset = OpenDataset(dir);
  ExpectInvalid([&] { dataset->Load(1); }, {"100.102000.png", "8-bit", "depth.txt:3"});
}

TEST(DatasetTest, SizeMismatchBetweenRgbAndDepth) {
  const std::string dir = TestTempDir() + "/mismatch";
  SmallDataset data(dir, 2);
  WriteDepth16(dir + "/depth/" + SmallDataset::Stamp(SmallDataset::DepthTime(0)) + ".png",
               SolidDepth(16, 12, 1));
  const auto dataset = OpenDataset(dir);
  ExpectInvalid([&] { dataset->Load(0); }, {"100.002000.png", "16x12", "32x24", "depth.txt:2"});
  // RGB not matching the camera.
  WriteRgb8(dir + "/rgb/" + SmallDataset::Stamp(SmallDataset::RgbTime(1)) + ".png", SolidRgb(30, 24, 0));
  ExpectInvalid([&] { dataset->Load(1); }, {"100.100000.png", "30x24", "rgb.txt:4"});
  // A mask of the wrong size.
  WriteGray8(dir + "/masks/" + SmallDataset::Stamp(SmallDataset::RgbTime(1)) + ".png", ImageU8(8, 8, 1, 0));
  WriteRgb8(dir + "/rgb/" + SmallDataset::Stamp(SmallDataset::RgbTime(1)) + ".png", SolidRgb(32, 24, 0));
  ExpectInvalid([&] { OpenDataset(dir)->Load(1); }, {"masks/100.100000.png", "8x8"});
}

TEST(DatasetTest, UnsortedTimestamps) {
  const std::string dir = TestTempDir() + "/unsorted";
  SmallDataset data(dir, 3);
  WriteText(dir + "/rgb.txt",
            "# comment\n100.000000 rgb/100.000000.png\n100.200000 rgb/100.200000.png\n"
            "100.100000 rgb/100.100000.png\n");
  ExpectInvalid([&] { OpenDataset(dir); }, {"rgb.txt:4", "100.100000", "increase"});
  // Unsorted ground truth, too.
  SmallDataset again(dir, 3);
  WriteText(dir + "/groundtruth.txt", "100.0 0 0 0 0 0 0 1\n100.0 0 0 0 0 0 0 1\n");
  ExpectInvalid([&] { OpenDataset(dir); }, {"groundtruth.txt:2"});
}

TEST(DatasetTest, MalformedListLines) {
  const std::string dir = TestTempDir() + "/malformed";
  SmallDataset data(dir, 2);
  WriteText(dir + "/rgb.txt", "100.000000 rgb/100.000000.png\nhello rgb/100.100000.png\n");
  ExpectInvalid([&] { OpenDataset(dir); }, {"rgb.txt:2", "expected 'timestamp path'", "hello"});
  WriteText(dir + "/rgb.txt", "100.000000\n");
  ExpectInvalid([&] { OpenDataset(dir); }, {"rgb.txt:1"});
  SmallDataset again(dir, 2);
  WriteText(dir + "/associations.txt", "100.000000 rgb/100.000000.png 100.002000\n");
  ExpectInvalid([&] { OpenDataset(dir); }, {"associations.txt:1", "t_rgb rgb_path t_depth depth_path"});
  WriteText(dir + "/associations.txt", "100.000000 rgb/other.png 100.002000 depth/100.002000.png\n");
  ExpectInvalid([&] { OpenDataset(dir); }, {"associations.txt:1", "rgb/other.png"});
  WriteText(dir + "/groundtruth.txt", "100.0 0 0 0 0 0 1\n");
  fs::remove(dir + "/associations.txt");
  ExpectInvalid([&] { OpenDataset(dir); }, {"groundtruth.txt:1"});
}

TEST(DatasetTest, AssociationsInEitherColumnOrder) {
  const std::string dir = TestTempDir() + "/reversed";
  SmallDataset data(dir, 2);
  // depth first, then RGB (as associate.py writes when given depth.txt first).
  WriteText(dir + "/associations.txt", "100.002000 depth/100.002000.png 100.000000 rgb/100.000000.png\n");
  const auto dataset = OpenDataset(dir);
  EXPECT_TRUE(dataset->info(0).has_depth);
  EXPECT_EQ(fs::path(dataset->info(0).depth_path).filename(), "100.002000.png");
  EXPECT_FALSE(dataset->info(1).has_depth);  // not in associations.txt
}

TEST(DatasetTest, DepthCaptureTimeFromPresetListOrOffset) {
  DYPHO_REQUIRE_SHARED_DATA("tum_fr1_rpy_head250");
  DatasetOptions options;
  options.depth_time = "listed";
  const auto listed = OpenDataset(SharedData("tum_fr1_rpy_head250"), options);
  options.depth_time = "0.015";
  const auto offset = OpenDataset(SharedData("tum_fr1_rpy_head250"), options);
  EXPECT_EQ(listed->depth_time_source(), "listed");
  EXPECT_NE(offset->depth_time_source().find("+0.015 s (given)"), std::string::npos);
  for (size_t i = 0; i < listed->size(); ++i) {
    const FrameInfo& a = listed->info(i);
    const FrameInfo& b = offset->info(i);
    ASSERT_DOUBLE_EQ(a.depth_timestamp, a.depth_listed_timestamp);
    ASSERT_DOUBLE_EQ(b.depth_listed_timestamp, a.depth_listed_timestamp);
    ASSERT_NEAR(b.depth_timestamp, b.timestamp + 0.015, 1e-9);
  }
  // Frames carry it; the associations put fr1's depth 0-14 ms after colour.
  EXPECT_NEAR(offset->Load(3).depth_timestamp, offset->info(3).timestamp + 0.015, 1e-9);
  EXPECT_GE(listed->info(0).depth_timestamp, listed->info(0).timestamp);
  // No preset offset for fr3: its listed timestamps.
  DYPHO_REQUIRE_SHARED_DATA("tum_fr3_walking_xyz_3frames");
  const auto fr3 = OpenDataset(SharedData("tum_fr3_walking_xyz_3frames"));
  EXPECT_EQ(fr3->depth_time_source(), "listed");
  EXPECT_DOUBLE_EQ(fr3->info(0).depth_timestamp, fr3->info(0).depth_listed_timestamp);
  for (const char* bad : {"soon", "0.5", "-0.2", "nan", ""}) {
    options.depth_time = bad;
    ExpectInvalid([&] { OpenDataset(SharedData("tum_fr1_rpy_head250"), options); }, {"depth_time"});
  }
}

TEST(DatasetTest, OptionsAreValidated) {
  DatasetOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error));
  options.max_depth_dt = 0.0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("max_depth_dt"), std::string::npos);
  options = DatasetOptions();
  options.depth_factor = -1.0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("depth_factor"), std::string::npos);
}

}  // namespace
}  // namespace dypho
