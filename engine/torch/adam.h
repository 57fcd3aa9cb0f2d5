// Adam with per-row step counts for the mapper (engine/torch/mapper.cc).
// Rows are Gaussians (or one pose / exposure row): rows added by insertion or
// densification start their own bias correction, so the optimiser needs no
// rebuild when the map grows. Kingma and Ba, "Adam", ICLR 2015 (update rule);
// beta1 0.9, beta2 0.999.
#pragma once

#include <cmath>
#include <vector>

#include <torch/torch.h>

namespace dypho {

constexpr double kAdamBeta1 = 0.9, kAdamBeta2 = 0.999, kAdamEps = 1e-15;

// One optimised tensor with its Adam moments and per-row step counts, so
// that rows added by insertion or densification start their own bias
// correction (rows are Gaussians; the pose twists use one row).
struct AdamParam {
  torch::Tensor value;  // requires_grad
  torch::Tensor m, v;   // same shape
  torch::Tensor steps;  // [rows] float
  float lr = 0.0f;

  void Init(torch::Tensor initial, float learning_rate) {
    value = initial.detach().clone().set_requires_grad(true);
    m = torch::zeros_like(value);
    v = torch::zeros_like(value);
    steps = torch::zeros({value.size(0)}, value.options().dtype(torch::kFloat32));  // on the value's device
    lr = learning_rate;
  }
  // One Adam step. With `visible` ([rows] bool) only those rows are updated
  // and counted (the "sparse" Adam of Gaussian-splatting trainers: a
  // Gaussian outside the view keeps its moments instead of decaying them);
  // on contiguous CPU float tensors this is one fused pass over the rows.
  // `rates`, when given, replaces `lr` by a tensor broadcast against the
  // value (e.g. [1, 6] rates per twist component).
  void Step(const torch::Tensor& visible = torch::Tensor(), const torch::Tensor& rates = torch::Tensor()) {
    torch::NoGradGuard no_grad;
    const torch::Tensor& g = value.grad();
    if (!g.defined()) return;
    if (visible.defined() && !rates.defined() && value.device().is_cpu() && value.scalar_type() == torch::kFloat32 &&
        value.is_contiguous() && m.is_contiguous() && v.is_contiguous() && steps.is_contiguous()) {
      const torch::Tensor gc = g.contiguous();
      const torch::Tensor vis = visible.to(torch::kBool).contiguous();
      const int64_t rows = value.size(0), cols = rows > 0 ? value.numel() / rows : 0;
      float* pv = value.data_ptr<float>();
      float* pm = m.data_ptr<float>();
      float* ps = v.data_ptr<float>();
      float* pn = steps.data_ptr<float>();
      const float* pg = gc.data_ptr<float>();
      const bool* pvis = vis.data_ptr<bool>();
      const float learning_rate = lr;
      at::parallel_for(0, rows, 4096, [&](int64_t begin, int64_t end) {
        for (int64_t i = begin; i < end; ++i) {
          if (!pvis[i]) continue;
          const float n = pn[i] += 1.0f;
          const float b1 = static_cast<float>(kAdamBeta1), b2 = static_cast<float>(kAdamBeta2);
          const float bc1 = 1.0f - std::pow(b1, n);
          const float inv_bc2 = 1.0f / (1.0f - std::pow(b2, n));
          const float step = learning_rate / bc1;
          for (int64_t c = i * cols; c < (i + 1) * cols; ++c) {
            const float gr = pg[c];
            pm[c] = b1 * pm[c] + (1.0f - b1) * gr;
            ps[c] = b2 * ps[c] + (1.0f - b2) * gr * gr;
            pv[c] -= step * pm[c] / (std::sqrt(ps[c] * inv_bc2) + static_cast<float>(kAdamEps));
          }
        }
      });
      value.mutable_grad().reset();
      return;
    }
    torch::Tensor rows_mask;
    if (visible.defined()) rows_mask = visible.to(torch::kBool);
    steps.add_(rows_mask.defined() ? rows_mask.to(torch::kFloat32) : torch::ones_like(steps));
    std::vector<int64_t> shape(value.dim(), 1);
    shape[0] = value.size(0);
    const torch::Tensor n = steps.clamp_min(1.0f);
    const torch::Tensor bc1 = (1.0 - torch::pow(kAdamBeta1, n)).view(shape);
    const torch::Tensor bc2 = (1.0 - torch::pow(kAdamBeta2, n)).view(shape);
    const torch::Tensor new_m = m * kAdamBeta1 + g * (1.0 - kAdamBeta1);
    const torch::Tensor new_v = v * kAdamBeta2 + g * g * (1.0 - kAdamBeta2);
    const torch::Tensor direction = (new_m / bc1) / ((new_v / bc2).sqrt() + kAdamEps);
    const torch::Tensor update = rates.defined() ? direction * rates : direction * lr;
    if (rows_mask.defined()) {
      const torch::Tensor keep = rows_mask.view(shape);
      m = torch::where(keep, new_m, m);
      v = torch::where(keep, new_v, v);
      value.sub_(update * keep.to(update.scalar_type()));
    } else {
      m = new_m;
      v = new_v;
      value.sub_(update);
    }
    value.mutable_grad().reset();
  }
  // Keeps the rows where `keep` is true.
  void Select(const torch::Tensor& keep) {
    torch::NoGradGuard no_grad;
    value = value.detach().index({keep}).clone().set_requires_grad(true);
    m = m.index({keep}).clone();
    v = v.index({keep}).clone();
    steps = steps.index({keep}).clone();
  }
  // Appends rows with fresh moments.
  void Append(const torch::Tensor& rows) {
    torch::NoGradGuard no_grad;
    value = torch::cat({value.detach(), rows.to(value.device(), value.scalar_type())}).set_requires_grad(true);
    m = torch::cat({m, torch::zeros(rows.sizes(), m.options())});
    v = torch::cat({v, torch::zeros(rows.sizes(), v.options())});
    steps = torch::cat({steps, torch::zeros({rows.size(0)}, steps.options())});
  }
  int64_t rows() const { return value.size(0); }
};


}  // namespace dypho
