#include "masking/mat_checks.h"

#include "common/check.h"

namespace dypho {

std::string MatTypeName(int type) {
  static const char* kDepths[] = {"CV_8U", "CV_8S", "CV_16U", "CV_16S", "CV_32S", "CV_32F", "CV_64F", "CV_16F"};
  return std::string(kDepths[CV_MAT_DEPTH(type)]) + "C" + std::to_string(CV_MAT_CN(type));
}

std::string SizeText(const cv::Size& size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

void CheckMat(const cv::Mat& image, int type, const cv::Size& size, const std::string& what) {
  DYPHO_CHECK_INPUT(!image.empty()) << what << " is empty";
  DYPHO_CHECK_INPUT(image.dims == 2) << what << " must be a 2-D image (has " << image.dims << " dimensions)";
  DYPHO_CHECK_INPUT(image.type() == type)
      << what << " must be " << MatTypeName(type) << " (is " << MatTypeName(image.type()) << ")";
  DYPHO_CHECK_INPUT(size.empty() || image.size() == size)
      << what << " is " << SizeText(image.size()) << " but must be " << SizeText(size);
}

void CheckOptionalMat(const cv::Mat& image, int type, const cv::Size& size, const std::string& what) {
  if (!image.empty()) CheckMat(image, type, size, what);
}

}  // namespace dypho
