// Sharpness of a keyframe image (the keyframe selector's sharpest-frame
// choice and the mapper's sharp sampling): plain C++, no OpenCV, so that the
// mapper builds where only LibTorch and the kernels are (tools/gpu_check).
//
// The steps are those of the OpenCV formulation it replaced, value for value
// (tests/image_sharpness_test.cc compares every step with OpenCV 4.6 on
// random and real images, even and odd sizes):
//   grey      RGB -> Y = (9798 R + 19235 G + 3735 B + 2^14) >> 15 (BT.601 in
//             15-bit fixed point: cv::cvtColor COLOR_RGB2GRAY on 8 bits, equal
//             on all 2^24 colours);
//   half      (w / 2) x (h / 2) by area averaging (cv::resize INTER_AREA:
//             for an exact halving the rounded mean of 2x2 blocks, else the
//             area-weighted mean in float, rounded to nearest even);
//   laplacian the 4-neighbour Laplacian, borders reflected without repeating
//             the edge pixel (cv::Laplacian ksize 1, BORDER_REFLECT_101);
//   mask      the dynamic mask at half size by nearest neighbour, its static
//             pixels eroded by a 5x5 square (two 3x3 erosions; outside the
//             image counts as static);
//   variance  over the static pixels (all without a mask), sums in double in
//             row-major order; fewer than 100 static pixels give 0.
#pragma once

#include <cstdint>
#include <vector>

#include "common/image.h"

namespace dypho {

// Sharpness of an RGB (or grey) image: variance of the Laplacian of its grey
// image at half resolution over pixels where `dynamic_mask` (may be empty;
// else the image's size, 1 channel) is 0.
double ImageSharpness(const ImageU8& rgb, const ImageU8& dynamic_mask);

namespace sharpness_steps {
// The steps above, exposed for the equality test.
ImageU8 Grey(const ImageU8& rgb);                              // 1 or 3 channels -> 1 channel
ImageU8 HalfArea(const ImageU8& grey);                         // 1 channel
ImageU8 HalfGreyOfRgb(const ImageU8& rgb);                     // HalfArea(Grey(rgb)) for 3 channels, even sizes
ImageF Laplacian(const ImageU8& grey);                         // 1 channel, same size
ImageU8 StaticMask(const ImageU8& dynamic_mask, int width, int height);  // 255 = static, eroded
}  // namespace sharpness_steps

}  // namespace dypho
