#include "masking/png_folder_segmenter.h"

#include <opencv2/imgproc.hpp>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "common/check.h"
#include "masking/mat_checks.h"

namespace dypho {

PngFolderSegmenter::PngFolderSegmenter(const SegmenterOptions& options)
    : folder_(options.png_folder), missing_is_empty_(options.png_missing_is_empty) {
  DYPHO_CHECK_INPUT(std::filesystem::is_directory(folder_))
      << "SegmenterOptions.png_folder '" << folder_ << "' is not a directory";
}

std::string PngFolderSegmenter::PathFor(const std::string& name) const {
  return (std::filesystem::path(folder_) / (name + ".png")).string();
}

Segmentation PngFolderSegmenter::Segment(const SegmenterInput& input) {
  CheckSegmenterInput(input);
  DYPHO_CHECK_INPUT(!input.name.empty()) << "png-folder segmenter needs the image name (SegmenterInput.name)";
  const std::string path = PathFor(input.name);
  Segmentation result;
  if (!std::filesystem::exists(path)) {
    DYPHO_CHECK_INPUT(missing_is_empty_) << "mask file '" << path << "' does not exist";
    result.mask = cv::Mat(input.rgb.size(), CV_8UC1, cv::Scalar(0));
    return result;
  }
  const cv::Mat mask = cv::imread(path, cv::IMREAD_GRAYSCALE);
  DYPHO_CHECK_INPUT(!mask.empty()) << "mask file '" << path << "' cannot be read as an image";
  // A mask of the full image for an image downscaled by an integer factor
  // (the pipeline's masking_downscale) is reduced to it: a pixel is dynamic
  // when any of its full-resolution pixels is.
  const cv::Size size = input.rgb.size();
  const bool integer_factor = mask.cols % size.width == 0 && mask.rows % size.height == 0 &&
                              mask.cols / size.width == mask.rows / size.height;
  DYPHO_CHECK_INPUT(mask.size() == size || integer_factor)
      << "mask file '" << path << "' is " << SizeText(mask.size()) << " but the image is " << SizeText(size)
      << " (nor a whole multiple of it)";
  if (mask.size() == size) {
    result.mask = mask > 0;
  } else {
    const int f = mask.cols / size.width;
    cv::Mat grown;
    cv::dilate(mask > 0, grown, cv::Mat::ones(f, f, CV_8UC1), cv::Point(0, 0));
    cv::resize(grown, result.mask, size, 0, 0, cv::INTER_NEAREST);
  }
  return result;
}

}  // namespace dypho
