// Semantic masks made offline by any other segmenter, read from a folder of
// 8-bit PNGs named like the images: <folder>/<name>.png, nonzero = dynamic
// (colour files are converted to grey).
#pragma once

#include <string>

#include "masking/segmenter.h"

namespace dypho {

class PngFolderSegmenter : public Segmenter {
 public:
  // Throws InvalidInput when options.png_folder is not a directory.
  explicit PngFolderSegmenter(const SegmenterOptions& options);

  // Throws InvalidInput naming the file when it is missing (unless
  // png_missing_is_empty), unreadable or not of the image's size, and when
  // input.name is empty.
  Segmentation Segment(const SegmenterInput& input) override;
  std::string Name() const override { return "png-folder"; }
  // The file read for image `name`.
  std::string PathFor(const std::string& name) const;

 private:
  std::string folder_;
  bool missing_is_empty_;
};

}  // namespace dypho
