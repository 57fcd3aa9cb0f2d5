// The ELAS-style matcher: the stages of engine/stereo/ in order.
#include <chrono>
#include <functional>

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
  // The left and right halves of stages 1, 3 and 4 are independent: two tasks
  // (each stage's output is the same as computed one after the other).
  auto both = [](const std::function<void(int)>& f) {
    cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& r) {
      for (int i = r.start; i < r.end; ++i) f(i);
    }, 2);
  };
  // 1. Sobel descriptors of both images.
  cv::Mat desc[2], texture[2];
  both([&](int i) {
    desc[i] = ComputeDescriptors(i == 0 ? left : right);
    texture[i] = DescriptorTexture(desc[i]);
  });
  const cv::Mat &desc_left = desc[0], &desc_right = desc[1], &texture_left = texture[0], &texture_right = texture[1];
  ms[0] = Ms(t);
  // 2. Robust support points on the candidate grid.
  const std::vector<SupportPoint> points = ComputeSupportPoints(desc_left, desc_right, texture_left, o);
  ms[1] = Ms(t);
  // 3. Delaunay triangulation -> piecewise-planar prior, for each image.
  cv::Mat prior[2];
  both([&](int i) { prior[i] = PlanePrior(points, left.size(), i == 1); });
  const cv::Mat &prior_left = prior[0], &prior_right = prior[1];
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
