#include "engine/dense/keyframe_points.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <opencv2/imgproc.hpp>

#include "common/check.h"
#include "engine/dense/voxel_key.h"

namespace dypho {
namespace {

// The mask dilated by `r` pixels (square neighbourhood), as 0/1.
std::vector<uint8_t> DilatedMask(const ImageU8& mask, int r) {
  const cv::Mat in(mask.height(), mask.width(), CV_8UC1, const_cast<uint8_t*>(mask.data()));
  cv::Mat binary, dilated;
  cv::threshold(in, binary, 0, 1, cv::THRESH_BINARY);
  if (r > 0) {
    cv::dilate(binary, dilated, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * r + 1, 2 * r + 1)));
  } else {
    dilated = binary;
  }
  return std::vector<uint8_t>(dilated.datastart, dilated.dataend);
}

bool ValidDepth(float d) { return std::isfinite(d) && d > 0.0f; }

}  // namespace

bool DensePointOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (stride < 1) return fail("stride must be >= 1 [px]");
  if (!(min_depth >= 0.0f && std::isfinite(min_depth))) return fail("min_depth must be >= 0 and finite [m]");
  if (!(max_depth > min_depth && std::isfinite(max_depth))) return fail("max_depth must be finite and > min_depth [m]");
  if (!(edge_ratio >= 0.0f && std::isfinite(edge_ratio))) return fail("edge_ratio must be >= 0 and finite");
  if (mask_margin_px < 0) return fail("mask_margin_px must be >= 0 [px]");
  return true;
}

KeyframePoints ExtractKeyframePoints(const Camera& camera, const KeyframeInput& keyframe,
                                     const DensePointOptions& options, double merge_voxel) {
  std::string error;
  DYPHO_CHECK_INPUT(options.IsValid(&error)) << "dense map: DensePointOptions: " << error;
  DYPHO_CHECK_INPUT(merge_voxel > 0 && std::isfinite(merge_voxel))
      << "dense map: voxel_size must be positive and finite (got " << merge_voxel << ")";
  const int w = camera.width, h = camera.height;
  DYPHO_CHECK_INPUT(keyframe.rgb.width() == w && keyframe.rgb.height() == h && keyframe.rgb.channels() == 3)
      << "dense map: keyframe at t=" << keyframe.timestamp << ": rgb is " << keyframe.rgb.width() << "x"
      << keyframe.rgb.height() << "x" << keyframe.rgb.channels() << ", expected " << w << "x" << h << "x3";
  DYPHO_CHECK_INPUT(keyframe.depth.empty() ||
                    (keyframe.depth.width() == w && keyframe.depth.height() == h && keyframe.depth.channels() == 1))
      << "dense map: keyframe at t=" << keyframe.timestamp << ": depth is " << keyframe.depth.width() << "x"
      << keyframe.depth.height() << "x" << keyframe.depth.channels() << ", expected " << w << "x" << h << "x1";
  DYPHO_CHECK_INPUT(keyframe.dynamic_mask.empty() || (keyframe.dynamic_mask.width() == w &&
                                                      keyframe.dynamic_mask.height() == h &&
                                                      keyframe.dynamic_mask.channels() == 1))
      << "dense map: keyframe at t=" << keyframe.timestamp << ": dynamic_mask is " << keyframe.dynamic_mask.width()
      << "x" << keyframe.dynamic_mask.height() << "x" << keyframe.dynamic_mask.channels() << ", expected " << w << "x"
      << h << "x1";
  KeyframePoints out;
  if (keyframe.depth.empty()) return out;

  std::vector<uint8_t> mask;
  if (!keyframe.dynamic_mask.empty()) {
    mask = DilatedMask(keyframe.dynamic_mask, options.mask_margin_px);
  }
  struct Sum {
    double xyz[3] = {0, 0, 0};
    uint32_t rgb[3] = {0, 0, 0};
    uint32_t count = 0;
  };
  std::vector<Sum> sums;
  std::unordered_map<VoxelKey, int, VoxelKeyHash> cell_of;
  cell_of.reserve(static_cast<size_t>(w / options.stride + 1) * (h / options.stride + 1) / 2);
  const double inv_voxel = 1.0 / merge_voxel;
  const ImageF& depth = keyframe.depth;
  for (int y = 0; y < h; y += options.stride) {
    for (int x = 0; x < w; x += options.stride) {
      if (!mask.empty() && mask[static_cast<size_t>(y) * w + x]) {
        ++out.masked;
        continue;
      }
      const float d = depth.at(x, y);
      if (!ValidDepth(d)) {
        ++out.no_depth;
        continue;
      }
      if (d < options.min_depth || d > options.max_depth) {
        ++out.out_of_range;
        continue;
      }
      if (options.edge_ratio > 0) {
        bool edge = false;
        const int nx[4] = {x - 1, x + 1, x, x};
        const int ny[4] = {y, y, y - 1, y + 1};
        for (int n = 0; n < 4 && !edge; ++n) {
          if (nx[n] < 0 || ny[n] < 0 || nx[n] >= w || ny[n] >= h) continue;
          const float dn = depth.at(nx[n], ny[n]);
          edge = ValidDepth(dn) && std::abs(dn - d) > options.edge_ratio * d;
        }
        if (edge) {
          ++out.edge;
          continue;
        }
      }
      ++out.used;
      const double p[3] = {(x - camera.cx) / camera.fx * d, (y - camera.cy) / camera.fy * d, double(d)};
      const VoxelKey key = KeyOf(p, inv_voxel);
      auto [it, inserted] = cell_of.emplace(key, static_cast<int>(sums.size()));
      if (inserted) sums.emplace_back();
      Sum& s = sums[it->second];
      for (int a = 0; a < 3; ++a) {
        s.xyz[a] += p[a];
        s.rgb[a] += keyframe.rgb.at(x, y, a);
      }
      ++s.count;
    }
  }
  out.xyz.reserve(3 * sums.size());
  out.rgb.reserve(3 * sums.size());
  out.weight.reserve(sums.size());
  for (const Sum& s : sums) {
    for (int a = 0; a < 3; ++a) {
      out.xyz.push_back(static_cast<float>(s.xyz[a] / s.count));
      out.rgb.push_back(static_cast<uint8_t>((s.rgb[a] + s.count / 2) / s.count));
    }
    out.weight.push_back(s.count);
  }
  return out;
}

}  // namespace dypho
