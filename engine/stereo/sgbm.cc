// OpenCV's StereoSGBM (Hirschmueller 2008) behind the disparity interface.
#include <opencv2/calib3d.hpp>

#include "engine/stereo/methods.h"

namespace dypho::stereo {

DisparityResult ComputeSgbm(const cv::Mat& left, const cv::Mat& right, const SgbmOptions& o) {
  const int range = ((o.max_disparity - o.min_disparity + 1) + 15) / 16 * 16;
  const int area = o.block_size * o.block_size;  // grey input: one channel
  auto matcher = cv::StereoSGBM::create(o.min_disparity, range, o.block_size, o.p1_per_pixel * area,
                                        o.p2_per_pixel * area, o.disp12_max_diff, 0,
                                        o.uniqueness_ratio, o.speckle_window, o.speckle_range,
                                        cv::StereoSGBM::MODE_SGBM_3WAY);
  cv::Mat fixed;  // CV_16S, disparity x 16, < min_disparity x 16 where invalid
  matcher->compute(left, right, fixed);
  DisparityResult result;
  fixed.convertTo(result.disparity, CV_32F, 1.0 / 16);
  result.valid = fixed >= o.min_disparity * 16;
  result.disparity.setTo(0, ~result.valid);
  // SGBM has already applied its uniqueness and left-right checks (disp12_max_diff):
  // its estimates get confidence 1.
  result.valid.convertTo(result.confidence, CV_32F, 1.0 / 255);
  return result;
}

}  // namespace dypho::stereo
