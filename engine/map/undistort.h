// Removing lens distortion from RGB-D frames before mapping: the rasterizer
// renders ideal pinhole images, so keyframes are resampled to the pinhole
// camera with the same fx, fy, cx, cy and size (OpenCV's undistortion maps).
#pragma once

#include <memory>

#include "common/camera.h"
#include "common/image.h"

namespace dypho {

class Undistorter {
 public:
  // `camera` may or may not have distortion; without it every call is a copy.
  explicit Undistorter(const Camera& camera);
  ~Undistorter();
  // The camera of the undistorted images (distortion zero).
  const Camera& pinhole() const { return pinhole_; }
  bool active() const { return maps_ != nullptr; }
  // Colour/grey: bilinear. Depth and masks: nearest neighbour (no mixing of
  // depths across edges). Pixels that map outside the input become 0.
  // Throws InvalidInput when the image size differs from the camera's.
  ImageU8 Rgb(const ImageU8& image) const;
  ImageF Depth(const ImageF& depth) const;
  ImageU8 Mask(const ImageU8& mask) const;
  // 255 where the undistorted image has data (its source pixel lies inside
  // the input, one pixel margin), 0 elsewhere; all 255 without distortion.
  const ImageU8& Valid() const { return valid_; }
  // `mask` (may be empty) with every pixel outside Valid() marked (255):
  // the pixels to exclude from training and scoring.
  ImageU8 ExcludedPixels(const ImageU8& dynamic_mask) const;

 private:
  struct Maps;
  Camera pinhole_;
  std::unique_ptr<Maps> maps_;
  ImageU8 valid_;
};

}  // namespace dypho
