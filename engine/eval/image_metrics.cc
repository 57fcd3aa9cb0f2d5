#include "engine/eval/image_metrics.h"

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "common/check.h"

namespace dypho {
namespace {

constexpr int kSsimWindow = 11;          // window side [px]
constexpr double kSsimSigma = 1.5;       // Gaussian sigma [px]
constexpr double kSsimC1 = 0.01 * 0.01;  // (K1 L)^2 with L = 1
constexpr double kSsimC2 = 0.03 * 0.03;  // (K2 L)^2 with L = 1

template <typename A, typename B>
void CheckSameShape(const Image<A>& a, const Image<B>& b, const char* what) {
  DYPHO_CHECK_INPUT(a.width() == b.width() && a.height() == b.height() && a.channels() == b.channels())
      << what << ": images differ in size: " << a.width() << "x" << a.height() << "x" << a.channels()
      << " vs " << b.width() << "x" << b.height() << "x" << b.channels();
}

template <typename T>
void CheckMask(const Image<T>& image, const ImageU8& mask, const char* what) {
  if (mask.empty()) return;
  DYPHO_CHECK_INPUT(mask.channels() == 1 && mask.width() == image.width() && mask.height() == image.height())
      << what << ": mask must be " << image.width() << "x" << image.height() << "x1 (got " << mask.width()
      << "x" << mask.height() << "x" << mask.channels() << ")";
}

inline bool Included(const ImageU8& mask, size_t pixel) { return mask.empty() || mask.data()[pixel] != 0; }

inline bool ValidDepth(float d) { return std::isfinite(d) && d > 0.0f; }

}  // namespace

double Psnr(const ImageF& a, const ImageF& b, const ImageU8& mask) {
  CheckSameShape(a, b, "Psnr");
  CheckMask(a, mask, "Psnr");
  const size_t pixels = static_cast<size_t>(a.width()) * a.height();
  const int channels = a.channels();
  double sum_sq = 0.0;
  size_t count = 0;
  for (size_t p = 0; p < pixels; ++p) {
    if (!Included(mask, p)) continue;
    for (int c = 0; c < channels; ++c) {
      const double d = static_cast<double>(a.data()[p * channels + c]) - b.data()[p * channels + c];
      sum_sq += d * d;
    }
    count += channels;
  }
  if (count == 0) return std::numeric_limits<double>::quiet_NaN();
  const double mse = sum_sq / static_cast<double>(count);
  if (mse == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(1.0 / mse);
}

double Ssim(const ImageF& a, const ImageF& b, const ImageU8& mask) {
  CheckSameShape(a, b, "Ssim");
  CheckMask(a, mask, "Ssim");
  const int width = a.width(), height = a.height(), channels = a.channels();
  const int half = kSsimWindow / 2;
  if (width < kSsimWindow || height < kSsimWindow) return std::numeric_limits<double>::quiet_NaN();

  // Normalised 1-D Gaussian; its outer product is the 2-D window of the
  // reference implementation (fspecial('gaussian', 11, 1.5)).
  const cv::Mat kernel = cv::getGaussianKernel(kSsimWindow, kSsimSigma, CV_64F);
  auto filter = [&](const cv::Mat& in) {
    cv::Mat out;
    cv::sepFilter2D(in, out, CV_64F, kernel, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_CONSTANT);
    return out;
  };

  cv::Mat weight(height, width, CV_64F);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      weight.at<double>(y, x) = Included(mask, static_cast<size_t>(y) * width + x) ? 1.0 : 0.0;
    }
  }
  const cv::Mat weight_sum = filter(weight);

  double ssim_sum = 0.0;
  size_t count = 0;
  for (int c = 0; c < channels; ++c) {
    cv::Mat x(height, width, CV_64F), y(height, width, CV_64F);
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        x.at<double>(v, u) = a.at(u, v, c);
        y.at<double>(v, u) = b.at(u, v, c);
      }
    }
    const cv::Mat wx = weight.mul(x), wy = weight.mul(y);
    const cv::Mat sum_x = filter(wx), sum_y = filter(wy);
    const cv::Mat sum_xx = filter(wx.mul(x)), sum_yy = filter(wy.mul(y)), sum_xy = filter(wx.mul(y));
    for (int v = half; v < height - half; ++v) {
      for (int u = half; u < width - half; ++u) {
        if (weight.at<double>(v, u) == 0.0) continue;
        const double w = weight_sum.at<double>(v, u);
        const double mu_x = sum_x.at<double>(v, u) / w;
        const double mu_y = sum_y.at<double>(v, u) / w;
        const double var_x = sum_xx.at<double>(v, u) / w - mu_x * mu_x;
        const double var_y = sum_yy.at<double>(v, u) / w - mu_y * mu_y;
        const double cov_xy = sum_xy.at<double>(v, u) / w - mu_x * mu_y;
        const double ssim = ((2.0 * mu_x * mu_y + kSsimC1) * (2.0 * cov_xy + kSsimC2)) /
                            ((mu_x * mu_x + mu_y * mu_y + kSsimC1) * (var_x + var_y + kSsimC2));
        ssim_sum += ssim;
        ++count;
      }
    }
  }
  if (count == 0) return std::numeric_limits<double>::quiet_NaN();
  return ssim_sum / static_cast<double>(count);
}

DepthL1Result DepthL1(const ImageF& depth_a, const ImageF& depth_b, const ImageU8& mask) {
  CheckSameShape(depth_a, depth_b, "DepthL1");
  DYPHO_CHECK_INPUT(depth_a.channels() == 1)
      << "DepthL1: depth images must have 1 channel (got " << depth_a.channels() << ")";
  CheckMask(depth_a, mask, "DepthL1");
  DepthL1Result result;
  double sum = 0.0;
  for (size_t p = 0; p < depth_a.size(); ++p) {
    if (!Included(mask, p)) continue;
    ++result.candidates;
    const float da = depth_a.data()[p], db = depth_b.data()[p];
    if (!ValidDepth(da) || !ValidDepth(db)) continue;
    sum += std::abs(static_cast<double>(da) - db);
    ++result.count;
  }
  result.l1 =
      result.count > 0 ? sum / static_cast<double>(result.count) : std::numeric_limits<double>::quiet_NaN();
  return result;
}

double MaskScores::Iou() const {
  const size_t denominator = true_positives + false_positives + false_negatives;
  return denominator == 0 ? 1.0 : static_cast<double>(true_positives) / denominator;
}

double MaskScores::Precision() const {
  const size_t denominator = true_positives + false_positives;
  return denominator == 0 ? 1.0 : static_cast<double>(true_positives) / denominator;
}

double MaskScores::Recall() const {
  const size_t denominator = true_positives + false_negatives;
  return denominator == 0 ? 1.0 : static_cast<double>(true_positives) / denominator;
}

MaskScores& MaskScores::operator+=(const MaskScores& other) {
  true_positives += other.true_positives;
  false_positives += other.false_positives;
  false_negatives += other.false_negatives;
  true_negatives += other.true_negatives;
  return *this;
}

MaskScores CompareMasks(const ImageU8& predicted, const ImageU8& ground_truth, const ImageU8& region) {
  CheckSameShape(predicted, ground_truth, "CompareMasks");
  DYPHO_CHECK_INPUT(predicted.channels() == 1)
      << "CompareMasks: masks must have 1 channel (got " << predicted.channels() << ")";
  CheckMask(predicted, region, "CompareMasks");
  MaskScores scores;
  for (size_t p = 0; p < predicted.size(); ++p) {
    if (!Included(region, p)) continue;
    const bool pred = predicted.data()[p] != 0;
    const bool truth = ground_truth.data()[p] != 0;
    if (pred && truth)
      ++scores.true_positives;
    else if (pred)
      ++scores.false_positives;
    else if (truth)
      ++scores.false_negatives;
    else
      ++scores.true_negatives;
  }
  return scores;
}

}  // namespace dypho
