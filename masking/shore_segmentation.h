// Shore / water / sky segmentation for boats and docks (the nearshore USV
// SLAM of Zhang et al., J. Mar. Sci. Eng. 2025): water and sky are masked so
// that no features come from ripples, reflections or clouds.
//
//  1. RGB -> HSV (OpenCV: hue in 0..179).
//  2. Otsu's threshold on the hue channel splits the pixels into a low-hue
//     class (reds, browns, yellows, greens: shore, buildings, vegetation) and
//     a high-hue class (cyans, blues: water and sky).
//  3. Inversion: the shore class becomes the foreground (255).
//  4. Erode (erode_px), dilate (dilate_px), erode (final_erode_px) the shore:
//     the first erosion removes shore-coloured specks in water and sky
//     (glints, small clouds, buoys), the dilation closes gaps in the shore,
//     the last erosion brings its boundary back.
//  5. The water/sky mask is everything that is not shore.
// Limitations: hue is circular and OpenCV's red wraps at 179/0, so saturated
// magenta-red content (hue > ~150) falls into the water/sky class; grey and
// white content (low saturation) has an unreliable hue. Off by default
// (MaskingOptions::use_shore).
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace dypho {

struct ShoreOptions {
  int erode_px = 5;            // first erosion kernel edge [px], 0..101 (0 = none)
  int dilate_px = 15;          // dilation kernel edge [px], 0..101
  int final_erode_px = 9;      // last erosion kernel edge [px], 0..101
  bool water_hue_high = true;  // water and sky are the high-hue (blue) class; false: the low-hue class
  double scale = 0.5;          // processed at this fraction of the image size (kernels in image px), (0, 1]

  bool IsValid(std::string* error) const;
};

struct ShoreSegmentation {
  cv::Mat water_sky;    // CV_8UC1, image size, 255 = water or sky (masked)
  double otsu_hue = 0;  // Otsu's hue threshold [OpenCV hue units 0..179]
};

// `rgb`: CV_8UC3 RGB. Throws InvalidInput for an empty or wrongly typed
// image or invalid options.
ShoreSegmentation SegmentShore(const cv::Mat& rgb, const ShoreOptions& options);

}  // namespace dypho
