// The rectified image pairs of a stereo folder, for tools that need only the images.
#pragma once

#include <string>
#include <vector>

namespace dypho::stereo {

struct ImagePair {
  std::string name;   // file name of the left image (same as the right one's)
  std::string left, right;  // paths
};

// Pairs of a folder in the KITTI odometry layout (image_0/ + image_1/, or
// image_2/ + image_3/ for colour), the EuRoC/ASL layout (mav0/cam0/data/ +
// mav0/cam1/data/) or the generic one (left/ + right/), sorted by name. Throws
// InvalidInput naming the folder when none of them is found, and naming the
// missing file when a left image has no right image of the same name.
std::vector<ImagePair> ListImagePairs(const std::string& folder);

}  // namespace dypho::stereo
