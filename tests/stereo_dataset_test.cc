// Stereo layouts as datasets: KITTI (real frames), generic and EuRoC fixtures
// written here (rectified and not), bad input.
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/dataset/dataset.h"
#include "engine/stereo/rig.h"
#include "tests/test_data.h"

namespace dypho {
namespace {
namespace fs = std::filesystem;

void Write(const std::string& path, const std::string& text) {
  fs::create_directories(fs::path(path).parent_path());
  std::ofstream(path) << text;
}

// Median of the valid depth in the central quarter of a frame.
double MedianDepth(const Frame& f) {
  std::vector<float> z;
  for (int y = f.depth.height() / 4; y < 3 * f.depth.height() / 4; ++y)
    for (int x = f.depth.width() / 4; x < 3 * f.depth.width() / 4; ++x)
      if (f.depth.data()[size_t(y) * f.depth.width() + x] > 0) z.push_back(f.depth.data()[size_t(y) * f.depth.width() + x]);
  if (z.empty()) return 0;
  std::nth_element(z.begin(), z.begin() + z.size() / 2, z.end());
  return z[z.size() / 2];
}

// A textured fronto-parallel plane at depth `depth` seen by a left camera K and
// a right camera at right_from_left (R, t): the right image is the plane's homography.
void WritePlanePair(const std::string& left, const std::string& right, const cv::Matx33d& K, const cv::Matx33d& R,
                    const cv::Vec3d& t, double depth, int seed) {
  cv::Mat texture(240, 320, CV_8U);
  cv::RNG rng(seed);
  rng.fill(texture, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0.8);
  const cv::Matx33d H = K * (R + t * cv::Matx13d(0, 0, 1) * (1.0 / depth)) * K.inv();
  cv::Mat warped;
  cv::warpPerspective(texture, warped, cv::Mat(H), texture.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  fs::create_directories(fs::path(left).parent_path());
  fs::create_directories(fs::path(right).parent_path());
  cv::imwrite(left, texture);
  cv::imwrite(right, warped);
}

const cv::Matx33d kK(300, 0, 159.5, 0, 300, 119.5, 0, 0, 1);

std::string StereoYaml(const cv::Matx33d& R, const cv::Vec3d& t) {
  std::ostringstream s;
  s << "width: 320\nheight: 240\nframe_rate: 20\n"
    << "left: {fx: 300, fy: 300, cx: 159.5, cy: 119.5}\n"
    << "right: {fx: 300, fy: 300, cx: 159.5, cy: 119.5, distortion: [0, 0, 0, 0, 0]}\n"
    << "right_from_left:\n  rotation: [";
  for (int k = 0; k < 9; ++k) s << (k ? ", " : "") << R(k / 3, k % 3);
  s << "]\n  translation: [" << t[0] << ", " << t[1] << ", " << t[2] << "]\n";
  return s.str();
}

TEST(StereoDataset, KittiRealFramesGiveTheRoadHeightOfSgbm) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const auto d = OpenDataset(testing::SharedData("kitti_stereo_51"));
  EXPECT_EQ(d->format(), "kitti");
  ASSERT_EQ(d->size(), 51u);
  ASSERT_NE(d->stereo(), nullptr);
  EXPECT_FALSE(d->stereo()->rectify);
  EXPECT_NEAR(d->stereo()->baseline, 386.1448 / 718.856, 1e-4);
  EXPECT_DOUBLE_EQ(d->camera().fx, 718.856);
  EXPECT_EQ(d->ground_truth().size(), 51u);
  EXPECT_NEAR(d->info(50).timestamp, 5.0, 1e-9);
  ASSERT_TRUE(d->info(0).world_from_cam_gt.has_value());
  const Frame f = d->Load(0);
  ASSERT_EQ(f.depth.width(), 1241);
  EXPECT_EQ(f.right.width(), 1241);
  // The road below the horizon: height = depth (v - cy) / fy, the camera's height
  // above the road (KITTI mounts it 1.65 m up; the road here tilts in a bend).
  // The same from OpenCV's SGBM on the same pixels must agree within 5 cm.
  auto road_height = [&](const ImageF& depth) {
    std::vector<double> heights;
    for (int v = 330; v < 370; ++v)
      for (int u = 560; u < 660; ++u) {
        const float z = depth.data()[size_t(v) * 1241 + u];
        if (z > 0) heights.push_back(z * (v - d->camera().cy) / d->camera().fy);
      }
    EXPECT_GT(heights.size(), 3000u);
    std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
    return heights.empty() ? 0.0 : heights[heights.size() / 2];
  };
  const double elas = road_height(f.depth);
  const cv::Mat left = cv::imread(d->info(0).rgb_path, cv::IMREAD_GRAYSCALE);
  const cv::Mat right = cv::imread(d->info(0).right_path, cv::IMREAD_GRAYSCALE);
  stereo::DisparityOptions sgbm_options;
  sgbm_options.method = stereo::DisparityMethod::kSgbm;
  const stereo::DisparityResult sgbm = stereo::ComputeDisparity(left, right, sgbm_options);
  const cv::Mat z = stereo::DisparityToDepth(sgbm.disparity, sgbm.valid, d->camera().fx, d->stereo()->baseline);
  ImageF sgbm_depth(z.cols, z.rows, 1);
  std::memcpy(sgbm_depth.data(), z.ptr<float>(), z.total() * sizeof(float));
  const double reference = road_height(sgbm_depth);
  std::printf("road: camera height %.3f m (elas), %.3f m (sgbm)\n", elas, reference);
  EXPECT_NEAR(elas, reference, 0.05);
  EXPECT_GT(elas, 1.35);
  EXPECT_LT(elas, 1.8);
}

TEST(StereoDataset, GenericRectifiedPairGivesExactDepth) {
  const std::string dir = testing::TestTempDir() + "/seq";
  const cv::Vec3d t(-0.1, 0, 0);  // right camera 10 cm to the right
  for (int i = 0; i < 2; ++i)
    WritePlanePair(dir + "/left/" + std::to_string(i) + ".png", dir + "/right/" + std::to_string(i) + ".png", kK,
                   cv::Matx33d::eye(), t, 2.0, i);
  Write(dir + "/stereo.yaml", StereoYaml(cv::Matx33d::eye(), t));
  Write(dir + "/groundtruth.txt", "0 0 0 0 0 0 0 1\n0.05 0.1 0 0 0 0 0 1\n");
  const auto d = OpenDataset(dir);
  EXPECT_EQ(d->format(), "stereo");
  ASSERT_EQ(d->size(), 2u);
  EXPECT_FALSE(d->stereo()->rectify);
  EXPECT_NEAR(d->stereo()->baseline, 0.1, 1e-12);
  ASSERT_TRUE(d->info(1).world_from_cam_gt.has_value());
  EXPECT_NEAR(d->info(1).world_from_cam_gt->translation.x(), 0.1, 1e-9);
  const Frame f = d->Load(1);
  // Disparity 300 * 0.1 / 2 = 15 px: depth 2 m.
  EXPECT_NEAR(MedianDepth(f), 2.0, 0.005);
  // The same with OpenCV's SGBM (DatasetOptions::stereo_method, `dypho run --stereo-method`).
  DatasetOptions sgbm;
  sgbm.stereo_method = "sgbm";
  const auto d_sgbm = OpenDataset(dir, sgbm);
  EXPECT_EQ(d_sgbm->stereo()->disparity.method, stereo::DisparityMethod::kSgbm);
  EXPECT_NEAR(MedianDepth(d_sgbm->Load(1)), 2.0, 0.01);
  sgbm.stereo_method = "bm";
  EXPECT_THROW(OpenDataset(dir, sgbm), InvalidInput);
}

TEST(StereoDataset, GenericUnrectifiedPairIsRectified) {
  const std::string dir = testing::TestTempDir() + "/seq";
  const cv::Matx33d R = [] {
    cv::Matx33d r;
    cv::Rodrigues(cv::Vec3d(0.01, 0.03, 0.005), r);
    return r;
  }();
  const cv::Vec3d t(-0.12, 0.004, 0.002);
  WritePlanePair(dir + "/left/a.png", dir + "/right/a.png", kK, R, t, 2.0, 7);
  Write(dir + "/stereo.yaml", StereoYaml(R, t));
  const auto d = OpenDataset(dir);
  ASSERT_TRUE(d->stereo()->rectify);
  EXPECT_NEAR(d->stereo()->baseline, cv::norm(t), 1e-6);
  // Without rectification the rows would be off by several pixels; rectified,
  // the plane (2 m along the left optical axis) is found at 2 m within 2 %.
  const Frame f = d->Load(0);
  std::printf("unrectified: median depth %.4f m\n", MedianDepth(f));
  EXPECT_NEAR(MedianDepth(f), 2.0, 0.04);
}

TEST(StereoDataset, EurocLayoutWithGroundTruth) {
  const std::string dir = testing::TestTempDir() + "/MH_01";
  const std::string mav = dir + "/mav0";
  // Body frame = cam0; cam1 is 11 cm to the right (T_BS of cam1: translation +0.11 x).
  const std::string sensor =
      "sensor_type: camera\nrate_hz: 20\nresolution: [320, 240]\ncamera_model: pinhole\n"
      "intrinsics: [300, 300, 159.5, 119.5]\ndistortion_model: radial-tangential\n"
      "distortion_coefficients: [0, 0, 0, 0]\n";
  Write(mav + "/cam0/sensor.yaml", sensor + "T_BS:\n  cols: 4\n  rows: 4\n  data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n");
  Write(mav + "/cam1/sensor.yaml", sensor + "T_BS:\n  cols: 4\n  rows: 4\n  data: [1, 0, 0, 0.11, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n");
  Write(mav + "/cam0/data.csv", "#timestamp [ns],filename\n1000000000,1000000000.png\n1050000000,1050000000.png\n");
  Write(mav + "/cam1/data.csv", "#timestamp [ns],filename\n1000000000,1000000000.png\n1050000000,1050000000.png\n");
  for (const char* name : {"1000000000.png", "1050000000.png"})
    WritePlanePair(mav + "/cam0/data/" + name, mav + "/cam1/data/" + name, kK, cv::Matx33d::eye(),
                   cv::Vec3d(-0.11, 0, 0), 3.0, 3);
  Write(mav + "/state_groundtruth_estimate0/data.csv",
        "#timestamp, p_x, p_y, p_z, q_w, q_x, q_y, q_z\n900000000,0,0,0,1,0,0,0\n1100000000,1,2,0,1,0,0,0\n");
  const auto d = OpenDataset(dir);
  EXPECT_EQ(d->format(), "euroc");
  ASSERT_EQ(d->size(), 2u);
  EXPECT_NEAR(d->info(1).timestamp, 1.05, 1e-9);
  EXPECT_FALSE(d->stereo()->rectify);  // identical pinhole cameras side by side
  EXPECT_NEAR(d->stereo()->baseline, 0.11, 1e-9);
  ASSERT_TRUE(d->info(0).world_from_cam_gt.has_value());
  EXPECT_NEAR(d->info(0).world_from_cam_gt->translation.x(), 0.5, 1e-9);  // interpolated at 1.0 s
  EXPECT_NEAR(d->info(1).world_from_cam_gt->translation.y(), 1.5, 1e-9);
  EXPECT_NEAR(MedianDepth(d->Load(0)), 3.0, 0.01);  // disparity 11 px
}

// The message of the InvalidInput that `f` throws.
template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const InvalidInput& e) {
    return e.message();
  }
  return "(no error)";
}

TEST(StereoDataset, BadInputNamesFileAndLine) {
  const std::string dir = testing::TestTempDir();
  const std::string p0 = "P0: 700 0 30 0 0 700 20 0 0 0 1 0\n";
  auto kitti = [&](const std::string& name, const std::string& calib, bool right = true) {
    const std::string k = dir + "/" + name;
    Write(k + "/calib.txt", calib);
    fs::create_directories(k + "/image_0");
    fs::create_directories(k + "/image_1");
    cv::imwrite(k + "/image_0/000000.png", cv::Mat(40, 60, CV_8U, cv::Scalar(1)));
    if (right) cv::imwrite(k + "/image_1/000000.png", cv::Mat(40, 60, CV_8U, cv::Scalar(1)));
    return k;
  };
  EXPECT_NE(ErrorOf([&] { OpenDataset(kitti("zero", p0 + "P1: 700 0 30 0 0 700 20 0 0 0 1 0\n")); })
                .find("calib.txt:2: zero baseline"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { OpenDataset(kitti("nan", p0 + "P1: 700 0 30 nan 0 700 20 0 0 0 1 0\n")); })
                .find("calib.txt:2: non-finite number 'nan'"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { OpenDataset(kitti("short", p0 + "P1: 700 0 30\n")); }).find("calib.txt:2: P1 needs 12"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { OpenDataset(kitti("noright", p0 + "P1: 700 0 30 -350 0 700 20 0 0 0 1 0\n", false)); })
                .find("image_1/000000.png: missing right image"),
            std::string::npos);
  // Sizes that disagree: found when the frame is loaded.
  const std::string sizes = kitti("sizes", p0 + "P1: 700 0 30 -350 0 700 20 0 0 0 1 0\n");
  cv::imwrite(sizes + "/image_1/000000.png", cv::Mat(40, 62, CV_8U, cv::Scalar(1)));
  const auto d = OpenDataset(sizes);
  EXPECT_NE(ErrorOf([&] { d->Load(0); }).find("stereo images differ in size"), std::string::npos);
  Write(sizes + "/times.txt", "0\n0.1\n");
  EXPECT_NE(ErrorOf([&] { OpenDataset(sizes); }).find("times.txt: 2 times for 1 images"), std::string::npos);
  // Generic: the translation's line is named for a zero baseline.
  const std::string g = dir + "/generic";
  Write(g + "/stereo.yaml", StereoYaml(cv::Matx33d::eye(), cv::Vec3d(0, 0, 0)));
  fs::create_directories(g + "/left");
  fs::create_directories(g + "/right");
  EXPECT_NE(ErrorOf([&] { OpenDataset(g); }).find("stereo.yaml:8: zero baseline"), std::string::npos)
      << ErrorOf([&] { OpenDataset(g); });
}

}  // namespace
}  // namespace dypho
