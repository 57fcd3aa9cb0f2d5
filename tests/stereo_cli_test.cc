// `dypho disparity` on a Middlebury pair and on a stereo folder written here.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/test_data.h"

namespace dypho {
namespace {

std::string Dypho() { return std::string(DYPHO_BINARY_DIR) + "/tools/dypho"; }

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(StereoCli, MiddleburyPairGivesKittiPng) {
  DYPHO_REQUIRE_SHARED_DATA("middlebury/cones");
  const std::string dir = testing::TestTempDir(), data = testing::SharedData("middlebury/cones/");
  const std::string command = Dypho() + " disparity " + data + "im2.png " + data + "im6.png --out " + dir +
                              "/cones.png --max-disparity 64 --colour > " + dir + "/log.txt 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << ReadText(dir + "/log.txt");
  const cv::Mat png = cv::imread(dir + "/cones.png", cv::IMREAD_UNCHANGED);
  const cv::Mat truth = cv::imread(data + "disp2.png", cv::IMREAD_GRAYSCALE);  // disparity x 4
  ASSERT_EQ(png.type(), CV_16U);
  ASSERT_EQ(png.size(), truth.size());
  int total = 0, bad = 0;
  for (int y = 0; y < png.rows; ++y)
    for (int x = 0; x < png.cols; ++x) {
      if (truth.at<uint8_t>(y, x) == 0) continue;
      ++total;
      const uint16_t v = png.at<uint16_t>(y, x);
      if (v == 0 || std::abs(v / 256.0 - truth.at<uint8_t>(y, x) / 4.0) > 2.0) ++bad;
    }
  // The library test measures 0.092 for the same pair.
  EXPECT_LT(double(bad) / total, 0.12);
  const cv::Mat colour = cv::imread(dir + "/cones_colour.png", cv::IMREAD_UNCHANGED);
  EXPECT_EQ(colour.type(), CV_8UC3);
  EXPECT_EQ(colour.size(), png.size());
}

// A generic folder (left/, right/) of two pairs at disparities 7 and 15.
TEST(StereoCli, FolderGivesOnePngPerPair) {
  const std::string dir = testing::TestTempDir();
  std::filesystem::create_directories(dir + "/seq/left");
  std::filesystem::create_directories(dir + "/seq/right");
  const int disparities[2] = {7, 15};
  for (int i = 0; i < 2; ++i) {
    cv::Mat texture(120, 260, CV_8U);
    cv::RNG rng(10 + i);
    rng.fill(texture, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0.8);
    const std::string name = "00000" + std::to_string(i) + ".png";
    cv::imwrite(dir + "/seq/left/" + name, texture(cv::Rect(20, 0, 200, 120)));
    cv::imwrite(dir + "/seq/right/" + name, texture(cv::Rect(20 + disparities[i], 0, 200, 120)));
  }
  const std::string out = dir + "/out";
  const std::string command =
      Dypho() + " disparity " + dir + "/seq --out " + out + " --max-disparity 32 > " + dir + "/log.txt 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << ReadText(dir + "/log.txt");
  for (int i = 0; i < 2; ++i) {
    const cv::Mat png = cv::imread(out + "/00000" + std::to_string(i) + ".png", cv::IMREAD_UNCHANGED);
    ASSERT_EQ(png.type(), CV_16U) << i;
    int good = 0;
    for (int y = 0; y < png.rows; ++y)
      for (int x = 0; x < png.cols; ++x) good += std::abs(png.at<uint16_t>(y, x) - 256 * disparities[i]) <= 64;
    EXPECT_GT(good, 0.995 * png.total()) << "pair " << i;
  }
  // A left image without a right one: exit code 2 and the missing file named.
  cv::imwrite(dir + "/seq/left/000002.png", cv::Mat(120, 200, CV_8U, cv::Scalar(9)));
  const std::string bad = Dypho() + " disparity " + dir + "/seq --out " + out + " > " + dir + "/bad.txt 2>&1";
  EXPECT_EQ(WEXITSTATUS(std::system(bad.c_str())), 2);
  EXPECT_NE(ReadText(dir + "/bad.txt").find("right/000002.png: missing right image"), std::string::npos)
      << ReadText(dir + "/bad.txt");
}

// `dypho eval --kitti` on kitti_stereo_51: the ground truth against itself
// gives 0 %; against itself with every position scaled by 1.1 (about the
// first pose, which is the origin), no rotation error and a translation
// error of 10 % of each segment's straight-line length over its nominal
// length (a bend and the overshoot of the last frame: 9-11 %).
TEST(StereoCli, EvalKittiMetricOnKnownTrajectories) {
  DYPHO_REQUIRE_SHARED_DATA("kitti_stereo_51");
  const std::string dir = testing::TestTempDir(), data = testing::SharedData("kitti_stereo_51");
  ASSERT_EQ(std::system((Dypho() + " kitti-to-tum " + data + "/poses.txt --times " + data + "/times.txt --out " + dir +
                         "/gt.txt > " + dir + "/log.txt 2>&1").c_str()),
            0)
      << ReadText(dir + "/log.txt");
  {
    std::ifstream in(dir + "/gt.txt");
    std::ofstream out(dir + "/scaled.txt");
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream f(line);
      double t, x, y, z, qx, qy, qz, qw;
      f >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
      out.precision(12);
      out << t << " " << 1.1 * x << " " << 1.1 * y << " " << 1.1 * z << " " << qx << " " << qy << " " << qz << " "
          << qw << "\n";
    }
  }
  auto value = [&](const std::string& text, const std::string& key) {
    const size_t at = text.find(key + " ");
    return at == std::string::npos ? -1.0 : std::stod(text.substr(at + key.size() + 1));
  };
  for (const auto& [est, expected, tolerance] :
       {std::tuple<std::string, double, double>{"gt.txt", 0.0, 1e-6}, {"scaled.txt", 10.0, 1.0}}) {
    const std::string command =
        Dypho() + " eval --gt " + data + " --est " + dir + "/" + est + " --kitti auto > " + dir + "/eval.txt 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0) << ReadText(dir + "/eval.txt");
    const std::string text = ReadText(dir + "/eval.txt");
    EXPECT_NE(text.find("kitti_lengths 10,20,30,40,50 m"), std::string::npos) << text;
    EXPECT_GT(value(text, "kitti_segments"), 50) << text;
    EXPECT_NEAR(value(text, "kitti_translation_error"), expected, tolerance) << est << "\n" << text;
    EXPECT_NEAR(value(text, "kitti_rotation_error"), 0.0, 1e-5) << est << "\n" << text;
  }
  const std::string bad = Dypho() + " eval --gt " + data + " --est " + dir + "/gt.txt --kitti 10,x > " + dir +
                          "/bad.txt 2>&1";
  EXPECT_NE(std::system(bad.c_str()), 0);
  EXPECT_NE(ReadText(dir + "/bad.txt").find("--kitti: 'x'"), std::string::npos) << ReadText(dir + "/bad.txt");
}

}  // namespace
}  // namespace dypho
