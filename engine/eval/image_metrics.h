// Image quality metrics for rendered vs real frames and dynamic-mask metrics.
// Every image metric takes an optional mask (ImageU8, 1 channel, same size;
// nonzero = pixel included, empty = all pixels) so that static regions can be
// scored alone. Colour images are float in [0, 1] (use ToFloat from
// engine/io/image_io.h for 8-bit images); depth is in metres with 0 (or a
// non-finite value) meaning invalid. Sizes and channel counts must agree,
// otherwise InvalidInput names both.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/image.h"

namespace dypho {

// Peak signal-to-noise ratio [dB] with peak value 1:
//   PSNR = 10 log10(1 / MSE), MSE over the included pixels and all channels.
// +infinity for identical images; NaN when the mask includes no pixel.
double Psnr(const ImageF& a, const ImageF& b, const ImageU8& mask = ImageU8());

// Structural similarity (Wang, Bovik, Sheikh, Simoncelli, IEEE TIP 2004) with
// the standard parameters: 11x11 Gaussian window, sigma 1.5, C1 = (0.01 L)^2,
// C2 = (0.03 L)^2 with L = 1. The SSIM map is evaluated at every pixel whose
// window lies inside the image (the "valid" region of the reference
// implementation) and averaged over those pixels and the channels.
// With a mask, only included pixels are averaged, and the local means,
// variances and covariance use the Gaussian weights restricted to included
// pixels (renormalised), so excluded content cannot affect the score; with an
// all-ones mask this is exactly the standard SSIM. Images smaller than 11x11
// or a mask without any valid window centre give NaN.
double Ssim(const ImageF& a, const ImageF& b, const ImageU8& mask = ImageU8());

// Mean absolute depth difference [m] over pixels where both depths are valid
// (finite and > 0) and the mask includes the pixel. NaN when there is none.
struct DepthL1Result {
  double l1 = 0.0;        // [m] mean |a - b|
  size_t count = 0;       // pixels compared
  size_t candidates = 0;  // pixels included by the mask (valid or not)
};
DepthL1Result DepthL1(const ImageF& depth_a, const ImageF& depth_b, const ImageU8& mask = ImageU8());

// Binary-mask agreement. Pixels are positive where nonzero.
struct MaskScores {
  size_t true_positives = 0;
  size_t false_positives = 0;
  size_t false_negatives = 0;
  size_t true_negatives = 0;

  // Ratios; when a denominator is 0 the ratio is 1 (nothing to get wrong:
  // no prediction, no ground truth, or both masks empty).
  double Iou() const;        // TP / (TP + FP + FN)
  double Precision() const;  // TP / (TP + FP)
  double Recall() const;     // TP / (TP + FN)
  // Adds the counts of `other` (to score a whole sequence at once).
  MaskScores& operator+=(const MaskScores& other);
};
// Compares a predicted mask against the ground truth, over the pixels that
// `region` includes (empty = all).
MaskScores CompareMasks(const ImageU8& predicted, const ImageU8& ground_truth,
                        const ImageU8& region = ImageU8());

}  // namespace dypho
