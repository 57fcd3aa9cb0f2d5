// The mask of an object inside a detection box, made from depth: the
// connected region at the box's dominant foreground depth.
//
//  1. Histogram (bins of `bin_size` m) of the valid depths in the box's core
//     (its central core_width x core_height part, where the object is most
//     likely to be), smoothed by [1 2 1].
//  2. The object's depth is the nearest histogram mode holding at least
//     `min_mode_fraction` of the core's valid depths (nearer content in front
//     of the object rarely fills that much of the core; farther background
//     loses to the object by being farther); when no mode is that large, the
//     largest mode. Its value is the median depth of the mode's three bins.
//     With min_box_iou > 0, when the region of that mode (step 3) covers
//     less than min_box_iou of the box (its bounding rectangle's share), the
//     next modes (at most 3 in all) are tried and the one covering the box
//     best is taken: a desk in front of a person standing behind it holds
//     the nearest mode but only the lower part of the box. A farther region
//     on both sides of the nearer one in the rows of its centre (a wall
//     beside a thin person) is not taken.
//  3. Seeds: core pixels within max(bin_size, step tolerance) of that depth.
//     Region growing over 4-neighbours inside the box: a neighbour joins when
//     its depth differs from the pixel's by at most
//     step_tolerance + step_tolerance_rel * z and from the object's depth by
//     at most range_tolerance.
//     With behind_min_height > 0, a farther layer touching the region and
//     as tall as a person joins it (see the option).
//  4. Holes enclosed by the region whose pixels have no depth or a depth
//     within range_tolerance are filled; a closing of close_px removes gaps.
// When the box has too few valid depths in its core (fewer than
// min_valid_fraction of the core's pixels), or no depth is given, the whole
// box is the mask.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace dypho {

struct DepthBoxMaskOptions {
  double bin_size = 0.05;    // depth histogram bin width [m], > 0
  double core_width = 0.5;   // the histogram uses this central fraction of the box width, (0, 1]
  double core_height = 0.6;  // ... and of the box height, (0, 1]
  double min_mode_fraction =
      0.15;                      // nearest mode with this fraction of the core's valid depths is the object's, (0, 1]
  double step_tolerance = 0.05;  // region growing: largest depth step between neighbours [m], >= 0
  double step_tolerance_rel = 0.03;  // ... plus this fraction of the depth [m/m], >= 0
  double range_tolerance = 0.6;      // region pixels lie within this distance of the object's depth [m], > 0
  double min_valid_fraction = 0.2;   // fewer valid depths in the core: the whole box is the mask, [0, 1]
  int close_px = 5;                  // closing kernel that fills small gaps in the region [px], 0..51 (0 = none)
  double max_depth = 10.0;           // depths beyond this are ignored [m], > 0
  bool whole_box = false;            // the whole box is the mask (depth not used)
  // A box this close to the image's left or right border [px] is the mask
  // whole (a person cut by the border: the depth region missed slivers of
  // them at the border, which then entered the map); -1 = never.
  int whole_box_border_px = -1;
  // The nearest mode's region gives way to a farther mode's when its
  // bounding rectangle covers less than this fraction of the box and the
  // farther one covers more (a person behind a desk: the desk's depth is the
  // nearest mode of the core); 0 = the nearest mode always, [0, 1].
  double min_box_iou = 0.0;
  // A person behind the object inside its box (YOLOX boxes two people, one
  // half hidden, once): a farther layer within range_tolerance that touches
  // the region, spans at least this fraction of the box's height and is not
  // on both sides of the region (a wall is) joins the mask; 0 = off, [0, 1].
  double behind_min_height = 0.0;

  bool IsValid(std::string* error) const;
};

struct BoxMask {
  cv::Rect roi;             // the box clipped to the image [px]
  cv::Mat mask;             // CV_8UC1 of roi's size, 255 = object
  float depth = 0.0f;       // [m] the object's depth, 0 when the whole box was used
  bool from_depth = false;  // false: the whole box (no or too little depth)
};

// `depth`: CV_32FC1 [m], 0 = invalid, or empty (then the whole box). Throws
// InvalidInput for a depth of another type or for invalid options.
BoxMask MaskFromDepthInBox(const cv::Mat& depth, const cv::Rect& box, const DepthBoxMaskOptions& options);

// The masks of several boxes of one image. A box whose region turns out to be
// mostly another box's object (a person behind another: the nearer person
// fills its core, so its dominant depth is the nearer person's) is done again
// with that box's region left out of its depth, so that it finds its own
// object. The owner of a shared region is the box it fills more.
std::vector<BoxMask> MasksFromDepthInBoxes(const cv::Mat& depth, const std::vector<cv::Rect>& boxes,
                                           const DepthBoxMaskOptions& options);

}  // namespace dypho
