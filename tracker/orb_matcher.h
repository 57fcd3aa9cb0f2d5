// Descriptor matching for the ORB tracker: Hamming distances on 256-bit
// descriptors, brute-force matching with a ratio test, a rotation-consistency
// filter, and a grid of features for searches in a window.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace dypho {

// A 256-bit descriptor as four 64-bit words (the bytes of a cv::Mat row).
using Descriptor = std::array<uint64_t, 4>;

inline int HammingDistance(const Descriptor& a, const Descriptor& b) {
  return __builtin_popcountll(a[0] ^ b[0]) + __builtin_popcountll(a[1] ^ b[1]) +
         __builtin_popcountll(a[2] ^ b[2]) + __builtin_popcountll(a[3] ^ b[3]);
}

// Rows of an [N, 32] CV_8UC1 matrix. Throws InvalidInput for another shape.
std::vector<Descriptor> DescriptorsFromMat(const cv::Mat& descriptors);

struct DescriptorMatch {
  int query = -1;     // index into the query set
  int train = -1;     // index into the train set
  int distance = 0;   // Hamming distance [bits]
};

// For every query descriptor, its nearest train descriptor when the distance
// is <= max_distance and < ratio * the second-nearest distance; each train
// descriptor is used at most once (the closer query wins). Train entries
// with train_usable[i] == 0 are skipped (pass nullptr to use all).
std::vector<DescriptorMatch> MatchBruteForce(const std::vector<Descriptor>& query,
                                             const std::vector<Descriptor>& train, int max_distance,
                                             double ratio, const std::vector<char>* train_usable = nullptr);

// Which matches agree on the rotation between the images: the angle
// differences [deg] are binned into `bins` bins over 360 deg and matches in
// the three most populated bins are kept (a bin is kept only when it holds
// at least 10% of the largest one). Returns one flag per entry.
std::vector<char> RotationConsistent(const std::vector<float>& angle_differences, int bins = 30);

// Features bucketed by position for window queries.
class FeatureGrid {
 public:
  // `points` in pixels of an image of the given size; points outside go to
  // the border cells. `cell` is the bucket edge [px].
  void Build(const std::vector<cv::Point2f>& points, int width, int height, int cell = 10);
  // Indices of the points within `radius` px of (x, y) (square window test
  // then exact distance), in bucket order.
  void Query(float x, float y, float radius, std::vector<int>* out) const;

 private:
  int cols_ = 0, rows_ = 0, cell_ = 10;
  std::vector<cv::Point2f> points_;
  std::vector<int> start_;    // [cols * rows + 1] offsets into order_
  std::vector<int> order_;    // point indices sorted by bucket
};

}  // namespace dypho
