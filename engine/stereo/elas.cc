// The ELAS-style matcher: the stages of engine/stereo/ in order.
#include <chrono>

#include "common/logging.h"
#include "engine/stereo/dense_match.h"
#include "engine/stereo/descriptor.h"
#include "engine/stereo/methods.h"
#include "engine/stereo/postprocess.h"
#include "engine/stereo/support_points.h"
#include "engine/stereo/triangulation.h"

namespace dypho::stereo {

namespace {
double Ms(std::chrono::steady_clock::time_point& since) {
  const auto now = std::chrono::steady_clock::now();
  const double ms = std::chrono::duration<double, std::milli>(now - since).count();
  since = now;
  return ms;
}
}  // namespace

DisparityResult ComputeElas(const cv::Mat& left, const cv::Mat& right, const ElasOptions& o) {
  auto t = std::chrono::steady_clock::now();
  double ms[5];
  const int threads_before = cv::getNumThreads();
  if (o.threads > 0) cv::setNumThreads(o.threads);
  // 1. Sobel descriptors of both images.
  const cv::Mat desc_left = ComputeDescriptors(left), desc_right = ComputeDescriptors(right);
  const cv::Mat texture_left = DescriptorTexture(desc_left), texture_right = DescriptorTexture(desc_right);
  ms[0] = Ms(t);
  // 2. Robust support points on the candidate grid.
  const std::vector<SupportPoint> points = ComputeSupportPoints(desc_left, desc_right, texture_left, o);
  ms[1] = Ms(t);
  // 3. Delaunay triangulation -> piecewise-planar prior, for each image.
  const cv::Mat prior_left = PlanePrior(points, left.size(), false);
  const cv::Mat prior_right = PlanePrior(points, left.size(), true);
  ms[2] = Ms(t);
  // 4. Per-pixel MAP disparity in both images.
  DenseMatch dense_left = MatchDense(desc_left, desc_right, texture_left, prior_left, points, false, o);
  const DenseMatch dense_right = MatchDense(desc_right, desc_left, texture_right, prior_right, points, true, o);
  ms[3] = Ms(t);
  // 5. Left-right check, small segments, gaps.
  cv::Mat disparity = dense_left.disparity;
  LeftRightCheck(disparity, dense_right.disparity, float(o.lr_threshold));
  RemoveSmallSegments(disparity, o.speckle_size, o.speckle_threshold);
  cv::Mat filled(disparity.size(), CV_8U, cv::Scalar(0));
  InterpolateGaps(disparity, o.gap_width, o.gap_smooth_threshold, o.extrapolate_borders, filled);
  if (o.threads > 0) cv::setNumThreads(threads_before);
  ms[4] = Ms(t);
  DYPHO_LOG(Debug) << "elas: " << points.size() << " support points; ms: descriptors " << ms[0]
                   << ", support " << ms[1] << ", triangulation " << ms[2] << ", dense " << ms[3]
                   << ", post-processing " << ms[4];

  DisparityResult result;
  result.valid = disparity >= 0;
  result.disparity = disparity;
  result.disparity.setTo(0, ~result.valid);
  result.confidence = dense_left.confidence;
  result.confidence.setTo(0, ~result.valid | filled);
  return result;
}

}  // namespace dypho::stereo
