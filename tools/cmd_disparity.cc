// dypho disparity: dense disparity of a rectified stereo pair, or of every pair
// of a stereo folder, as 16-bit PNGs in the KITTI convention.
#include <cstdio>
#include <filesystem>
#include <string>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/check.h"
#include "engine/stereo/disparity.h"
#include "engine/stereo/pair_folder.h"
#include "tools/cli_checks.h"
#include "tools/command.h"

namespace dypho::tools {
namespace {
namespace fs = std::filesystem;

cv::Mat Read(const std::string& path) {
  const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  DYPHO_CHECK_INPUT(!image.empty()) << path << ": not a readable image";
  DYPHO_CHECK_INPUT(image.depth() == CV_8U) << path << ": an 8-bit image is needed";
  return image;
}

void Write(const std::string& path, const cv::Mat& image) {
  DYPHO_CHECK_INPUT(cv::imwrite(path, image)) << path << ": could not be written";
}

std::string ColourPath(const std::string& png) {
  fs::path p(png);
  return (p.parent_path() / (p.stem().string() + "_colour.png")).string();
}

double Process(const std::string& left, const std::string& right, const std::string& out,
               const stereo::DisparityOptions& options, bool colour) {
  const stereo::DisparityResult r = stereo::ComputeDisparity(Read(left), Read(right), options);
  Write(out, stereo::DisparityToKitti16(r.disparity, r.valid));
  if (colour) Write(ColourPath(out), stereo::DisparityToColour(r.disparity, r.valid, float(options.elas.max_disparity)));
  const double density = cv::countNonZero(r.valid) / double(r.valid.total());
  std::printf("%s: %.0f ms, %.1f%% of pixels with a disparity\n", out.c_str(), r.seconds * 1e3, 100 * density);
  return r.seconds;
}

int RunDisparity(int argc, char** argv) {
  CLI::App app{
      "Dense disparity of the left image of a rectified stereo pair, written as a 16-bit PNG in the KITTI "
      "convention (value = disparity x 256, 0 = no estimate). Given a stereo folder (KITTI image_0/ + "
      "image_1/ or image_2/ + image_3/, EuRoC mav0/cam0/data/ + mav0/cam1/data/, or left/ + right/) "
      "instead of two images, --out is a folder and gets one PNG per pair.",
      "dypho disparity"};
  std::string left, right, out, method = "elas";
  int max_disparity = 128;
  bool colour = false;
  app.add_option("left", left, "left image, or a stereo folder")->required();
  app.add_option("right", right, "right image (not with a folder)");
  app.add_option("--out", out, "output PNG (a pair) or folder (a stereo folder)")->required()->check(NonEmptyPath());
  app.add_option("--method", method, "elas (ours, ELAS-style) or sgbm (OpenCV StereoSGBM)")
      ->capture_default_str()->check(CLI::IsMember({"elas", "sgbm"}));
  app.add_option("--max-disparity", max_disparity, "largest disparity searched [px]")
      ->capture_default_str()->check(CLI::Range(3, 255));
  app.add_flag("--colour", colour, "also write a colour-mapped picture (NAME_colour.png)");
  CLI11_PARSE(app, argc, argv);

  stereo::DisparityOptions options;
  options.method = stereo::ParseDisparityMethod(method);
  options.SetMaxDisparity(max_disparity);
  if (fs::is_directory(left)) {
    DYPHO_CHECK_INPUT(right.empty()) << "give a stereo folder alone, or two images (got folder " << left
                                     << " and " << right << ")";
    const auto pairs = stereo::ListImagePairs(left);
    fs::create_directories(out);
    double seconds = 0;
    for (const auto& pair : pairs)
      seconds += Process(pair.left, pair.right, (fs::path(out) / fs::path(pair.name).stem()).string() + ".png",
                         options, colour);
    std::printf("%zu pairs, %.1f ms a pair (%s)\n", pairs.size(), 1e3 * seconds / pairs.size(), method.c_str());
    return 0;
  }
  DYPHO_CHECK_INPUT(!right.empty()) << "a right image is needed with the left image " << left;
  DYPHO_CHECK_INPUT(fs::path(out).extension() == ".png") << "--out " << out << ": a .png file is needed";
  if (fs::path(out).has_parent_path()) fs::create_directories(fs::path(out).parent_path());
  Process(left, right, out, options, colour);
  return 0;
}

}  // namespace

DYPHO_COMMAND("disparity", "dense disparity of a stereo pair or folder (16-bit KITTI PNG)", RunDisparity);

}  // namespace dypho::tools
