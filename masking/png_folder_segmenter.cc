#include "masking/png_folder_segmenter.h"

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
  DYPHO_CHECK_INPUT(mask.size() == input.rgb.size()) << "mask file '" << path << "' is " << SizeText(mask.size())
                                                     << " but the image is " << SizeText(input.rgb.size());
  result.mask = mask > 0;
  return result;
}

}  // namespace dypho
