// The overlay writer (engine/pipeline/overlay_writer.h): on its own thread
// it writes the same files as drawing inline, from copies (the caller's
// images may change right after Write), and a write error reaches the
// caller through Finish.
#include "engine/pipeline/overlay_writer.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "tests/test_data.h"

namespace dypho {
namespace {

namespace fs = std::filesystem;

std::string Bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

TEST(OverlayWriter, ThreadedWritesWhatInlineWritesFromCopies) {
  const fs::path dir = fs::path(testing::TestTempDir()) / "overlay_writer";
  fs::remove_all(dir);
  fs::create_directories(dir / "inline");
  fs::create_directories(dir / "threaded");
  for (bool threaded : {false, true}) {
    OverlayWriter writer(threaded, 2);
    cv::Mat rgb(48, 64, CV_8UC3);
    MaskResult masks;
    masks.mask = cv::Mat(48, 64, CV_8UC1, cv::Scalar(0));
    for (int i = 0; i < 6; ++i) {
      rgb.setTo(cv::Scalar(20 * i, 100, 200 - 20 * i));
      masks.mask.setTo(0);
      cv::rectangle(masks.mask, cv::Rect(4 * i, 5, 12, 20), cv::Scalar(255), cv::FILLED);
      masks.detections = {Detection{}};
      masks.detections[0].box = cv::Rect2f(4.0f * i, 5, 12, 20);
      writer.Write((dir / (threaded ? "threaded" : "inline") / (std::to_string(i) + ".jpg")).string(), rgb, masks);
      // The caller's images change at once: the writer must have its own copies.
      rgb.setTo(cv::Scalar(0, 0, 0));
      masks.mask.setTo(255);
    }
    writer.Finish();
  }
  for (int i = 0; i < 6; ++i) {
    const std::string a = Bytes((dir / "inline" / (std::to_string(i) + ".jpg")).string());
    ASSERT_GT(a.size(), 100u) << i;
    EXPECT_EQ(a, Bytes((dir / "threaded" / (std::to_string(i) + ".jpg")).string())) << i;
  }
  // Different frames, different files.
  EXPECT_NE(Bytes((dir / "inline" / "0.jpg").string()), Bytes((dir / "inline" / "5.jpg").string()));
}

TEST(OverlayWriter, AnErrorOfTheWorkerReachesFinish) {
  const fs::path dir = fs::path(testing::TestTempDir()) / "overlay_writer_error";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "a_file") << "not a folder";
  OverlayWriter writer(true);
  MaskResult masks;
  masks.mask = cv::Mat(8, 8, CV_8UC1, cv::Scalar(0));
  writer.Write((dir / "a_file" / "a.jpg").string(), cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3)), masks);
  EXPECT_THROW(writer.Finish(), std::exception);
  writer.Finish();  // reported once
}

}  // namespace
}  // namespace dypho
