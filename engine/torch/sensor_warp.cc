#include "engine/torch/sensor_warp.h"

#include <cmath>
#include <vector>

#include "common/check.h"

namespace dypho {
namespace {

// Bilinear taps of position (x, y) in a w x h image: up to four (index, weight).
struct Taps {
  int64_t index[4];
  float weight[4];
  int count = 0;
};

inline Taps BilinearTaps(float x, float y, int64_t w, int64_t h) {
  Taps t;
  if (!(x > -1.0f && y > -1.0f && x < w && y < h)) return t;
  const float fx = std::floor(x), fy = std::floor(y);
  const int64_t x0 = static_cast<int64_t>(fx), y0 = static_cast<int64_t>(fy);
  const float ax = x - fx, ay = y - fy;
  const float wts[4] = {(1 - ax) * (1 - ay), ax * (1 - ay), (1 - ax) * ay, ax * ay};
  const int64_t xs[4] = {x0, x0 + 1, x0, x0 + 1}, ys[4] = {y0, y0, y0 + 1, y0 + 1};
  for (int k = 0; k < 4; ++k) {
    if (xs[k] < 0 || ys[k] < 0 || xs[k] >= w || ys[k] >= h || wts[k] == 0.0f) continue;
    t.index[t.count] = ys[k] * w + xs[k];
    t.weight[t.count] = wts[k];
    ++t.count;
  }
  return t;
}

// Taps of output pixel (x, y) under the 3x3 homography m (row-major).
inline Taps HomographyTaps(const float* m, int64_t x, int64_t y, int64_t w, int64_t h) {
  const float z = m[6] * x + m[7] * y + m[8];
  if (!(z > 1e-6f)) return Taps();
  return BilinearTaps((m[0] * x + m[1] * y + m[2]) / z, (m[3] * x + m[4] * y + m[5]) / z, w, h);
}

class SensorWarpFunction : public torch::autograd::Function<SensorWarpFunction> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& image,
                               const torch::Tensor& homographies) {
    const torch::Tensor img = image.contiguous();
    const torch::Tensor pos = homographies.contiguous();
    ctx->save_for_backward({pos});
    ctx->saved_data["shape"] = image.sizes().vec();
    const int64_t n = pos.size(0), h = img.size(0), w = img.size(1), c = img.size(2);
    torch::Tensor out = torch::zeros_like(img);
    const float* pi = img.data_ptr<float>();
    const float* pp = pos.data_ptr<float>();
    float* po = out.data_ptr<float>();
    const float scale = 1.0f / n;
    at::parallel_for(0, h, 8, [&](int64_t begin, int64_t end) {
      for (int64_t y = begin; y < end; ++y) {
        for (int64_t j = 0; j < n; ++j) {
          const float* m = pp + (j * h + y) * 9;
          for (int64_t x = 0; x < w; ++x) {
            const Taps t = HomographyTaps(m, x, y, w, h);
            float* o = po + (y * w + x) * c;
            for (int k = 0; k < t.count; ++k) {
              const float* src = pi + t.index[k] * c;
              const float wt = t.weight[k] * scale;
              for (int64_t ch = 0; ch < c; ++ch) o[ch] += wt * src[ch];
            }
          }
        }
      }
    });
    return out;
  }

  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list grads) {
    const torch::Tensor pos = ctx->get_saved_variables()[0];
    const std::vector<int64_t> shape = ctx->saved_data["shape"].toIntVector();
    const torch::Tensor g = grads[0].contiguous();
    const int64_t n = pos.size(0), h = shape[0], w = shape[1], c = shape[2];
    const float* pg = g.data_ptr<float>();
    const float* pp = pos.data_ptr<float>();
    const float scale = 1.0f / n;
    // Rows in parallel, each chunk scattering into its own buffer.
    const int64_t chunks = std::max<int64_t>(1, std::min<int64_t>(at::get_num_threads(), h));
    std::vector<torch::Tensor> partial(chunks);
    at::parallel_for(0, chunks, 1, [&](int64_t cb, int64_t ce) {
      for (int64_t chunk = cb; chunk < ce; ++chunk) {
        torch::Tensor buf = torch::zeros({h, w, c}, torch::kFloat32);
        float* pb = buf.data_ptr<float>();
        const int64_t y0 = h * chunk / chunks, y1 = h * (chunk + 1) / chunks;
        for (int64_t y = y0; y < y1; ++y) {
          for (int64_t j = 0; j < n; ++j) {
            const float* m = pp + (j * h + y) * 9;
            for (int64_t x = 0; x < w; ++x) {
              const Taps t = HomographyTaps(m, x, y, w, h);
              const float* gq = pg + (y * w + x) * c;
              for (int k = 0; k < t.count; ++k) {
                float* dst = pb + t.index[k] * c;
                const float wt = t.weight[k] * scale;
                for (int64_t ch = 0; ch < c; ++ch) dst[ch] += wt * gq[ch];
              }
            }
          }
        }
        partial[chunk] = buf;
      }
    });
    torch::Tensor grad_image = partial[0];
    for (int64_t i = 1; i < chunks; ++i) grad_image.add_(partial[i]);
    return {grad_image, torch::Tensor()};
  }
};

}  // namespace

torch::Tensor SensorWarp(const torch::Tensor& image, const torch::Tensor& homographies) {
  DYPHO_CHECK(image.dim() == 3 && homographies.dim() == 4 && homographies.size(1) == image.size(0) &&
              homographies.size(2) == 3 && homographies.size(3) == 3)
      << "SensorWarp: image [h, w, c] and homographies [n, h, 3, 3] of the same h";
  if (image.device().is_cpu() && image.scalar_type() == torch::kFloat32 &&
      homographies.scalar_type() == torch::kFloat32) {
    return SensorWarpFunction::apply(image, homographies);
  }
  // Other devices: grid_sample at the positions the homographies give
  // (normalised coordinates, align_corners = false).
  namespace F = torch::nn::functional;
  const int64_t n = homographies.size(0), h = image.size(0), w = image.size(1);
  const auto opts = homographies.options();
  const torch::Tensor xs = torch::arange(w, opts).view({1, 1, w}).expand({n, h, w});
  const torch::Tensor ys = torch::arange(h, opts).view({1, h, 1}).expand({n, h, w});
  auto entry = [&](int r, int c) { return homographies.select(2, r).select(2, c).unsqueeze(2); };  // [n, h, 1]
  const torch::Tensor z = entry(2, 0) * xs + entry(2, 1) * ys + entry(2, 2);
  const torch::Tensor valid = z > 1e-6;
  const torch::Tensor safe_z = torch::where(valid, z, torch::ones_like(z));
  const torch::Tensor px = torch::where(valid, (entry(0, 0) * xs + entry(0, 1) * ys + entry(0, 2)) / safe_z,
                                        torch::full_like(z, -1e6));
  const torch::Tensor py = torch::where(valid, (entry(1, 0) * xs + entry(1, 1) * ys + entry(1, 2)) / safe_z,
                                        torch::full_like(z, -1e6));
  const torch::Tensor grid = torch::stack({(px + 0.5) / w * 2.0 - 1.0, (py + 0.5) / h * 2.0 - 1.0}, 3);
  const torch::Tensor img = image.permute({2, 0, 1}).unsqueeze(0).expand({n, -1, -1, -1});
  const torch::Tensor sampled = F::grid_sample(
      img, grid, F::GridSampleFuncOptions().mode(torch::kBilinear).padding_mode(torch::kZeros).align_corners(false));
  return sampled.mean(0).permute({1, 2, 0});
}

}  // namespace dypho
