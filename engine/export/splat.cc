#include "engine/export/splat.h"

#include <algorithm>
#include <cmath>
#include <climits>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <vector>

#include "common/check.h"
#include "common/files.h"
#include "engine/export/cloud_checks.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the .splat writer assumes a little-endian host");

namespace dypho {
namespace {

constexpr size_t kSplatBytes = 32;

uint8_t QuantizeUnit(double v) {  // [0, 1] -> 0..255
  return static_cast<uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
}

uint8_t QuantizeQuat(double q) {  // [-1, 1] -> 0..255
  return static_cast<uint8_t>(std::clamp(std::lround(q * 128.0 + 128.0), 0L, 255L));
}

}  // namespace

void SaveSplat(const GaussianCloud& cloud, const std::string& path) {
  export_internal::CheckCloudForExport(cloud, path);
  const int n = cloud.size();
  const int k = cloud.sh_coeffs;

  // Importance in double, so that the order does not depend on float rounding.
  std::vector<double> importance(n);
  for (int i = 0; i < n; ++i) {
    const double log_volume = double(cloud.log_scales[3 * i]) + cloud.log_scales[3 * i + 1] + cloud.log_scales[3 * i + 2];
    importance[i] = std::exp(log_volume) * export_internal::Sigmoid(cloud.opacity_logits[i]);
  }
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return importance[a] > importance[b]; });

  std::vector<char> bytes(kSplatBytes * n);
  for (int r = 0; r < n; ++r) {
    const int i = order[r];
    char* out = bytes.data() + kSplatBytes * r;
    float scale[3];
    for (int a = 0; a < 3; ++a) {
      scale[a] = std::exp(cloud.log_scales[3 * i + a]);
      DYPHO_CHECK_INPUT(std::isfinite(scale[a]) && scale[a] > 0)
          << path << ": Gaussian " << i << " has log_scale " << cloud.log_scales[3 * i + a]
          << ", whose exponential is not a positive float32";
    }
    std::memcpy(out, &cloud.means[3 * i], 12);
    std::memcpy(out + 12, scale, 12);
    const float* dc = &cloud.sh[static_cast<size_t>(i) * k * 3];
    uint8_t* rgba = reinterpret_cast<uint8_t*>(out + 24);
    for (int c = 0; c < 3; ++c) rgba[c] = QuantizeUnit(ShDcToRgb(dc[c]));
    rgba[3] = QuantizeUnit(export_internal::Sigmoid(cloud.opacity_logits[i]));
    double q[4];
    export_internal::NormalizedQuat(cloud, i, path, q);
    uint8_t* rot = reinterpret_cast<uint8_t*>(out + 28);
    for (int j = 0; j < 4; ++j) rot[j] = QuantizeQuat(q[j]);
  }

  WriteFileAtomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    DYPHO_CHECK_INPUT(out.good()) << "cannot open " << tmp << " for writing";
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    DYPHO_CHECK_INPUT(out.good()) << "error writing " << tmp;
  });
}

GaussianCloud LoadSplat(const std::string& path) {
  DYPHO_CHECK_INPUT(std::filesystem::is_regular_file(path)) << "cannot open " << path << ": no such file";
  const std::string data = export_internal::ReadWholeFile(path);
  DYPHO_CHECK_INPUT(data.size() % kSplatBytes == 0)
      << path << ": size " << data.size() << " bytes is not a multiple of 32 (not a .splat file, or truncated)";
  const size_t n = data.size() / kSplatBytes;
  DYPHO_CHECK_INPUT(n <= static_cast<size_t>(INT32_MAX)) << path << ": too many splats";
  GaussianCloud cloud;
  cloud.sh_coeffs = 1;
  cloud.means.resize(3 * n);
  cloud.log_scales.resize(3 * n);
  cloud.quats.resize(4 * n);
  cloud.opacity_logits.resize(n);
  cloud.sh.resize(3 * n);
  for (size_t i = 0; i < n; ++i) {
    const char* in = data.data() + kSplatBytes * i;
    float mean[3], scale[3];
    std::memcpy(mean, in, 12);
    std::memcpy(scale, in + 12, 12);
    for (int a = 0; a < 3; ++a) {
      DYPHO_CHECK_INPUT(std::isfinite(mean[a])) << path << ": splat " << i << " has a non-finite position";
      DYPHO_CHECK_INPUT(std::isfinite(scale[a]) && scale[a] > 0)
          << path << ": splat " << i << " has scale " << scale[a] << " (must be positive and finite)";
      cloud.means[3 * i + a] = mean[a];
      cloud.log_scales[3 * i + a] = std::log(scale[a]);
    }
    const uint8_t* rgba = reinterpret_cast<const uint8_t*>(in + 24);
    for (int c = 0; c < 3; ++c) cloud.sh[3 * i + c] = RgbToShDc(rgba[c] / 255.0f);
    const double a = std::clamp(rgba[3] / 255.0, 0.5 / 255.0, 254.5 / 255.0);
    cloud.opacity_logits[i] = static_cast<float>(std::log(a / (1.0 - a)));
    const uint8_t* rot = reinterpret_cast<const uint8_t*>(in + 28);
    bool all_zero = true;
    for (int j = 0; j < 4; ++j) {
      cloud.quats[4 * i + j] = (rot[j] - 128) / 128.0f;
      all_zero = all_zero && rot[j] == 128;
    }
    if (all_zero) cloud.quats[4 * i] = 1.0f;
  }
  return cloud;
}

}  // namespace dypho
