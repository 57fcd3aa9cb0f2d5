// The mapper's densification and pruning (Kerbl et al. 2023) and its
// free-space carving (engine/map/mapper.h, CarveFreeSpace).
#include <algorithm>
#include <cmath>
#include <vector>

#include <torch/torch.h>

#include "common/check.h"
#include "common/logging.h"
#include "engine/torch/mapper_impl.h"

namespace dypho {

void Mapper::Impl::DensifyAndPrune() {
  torch::NoGradGuard no_grad;
  const int64_t n = size();
  if (n == 0) return;
  const torch::Tensor mean_grad = grad_accum / grad_count.clamp_min(1.0);
  const torch::Tensor max_scale = std::get<0>(log_scales.value.max(1)).exp();
  // In normalised device coordinates (x 2 / width) as Kerbl et al. 2023
  // give their threshold: the same value densifies alike at any resolution.
  const torch::Tensor mean_grad_ndc = mean_grad * (0.5 * train_camera.width);
  torch::Tensor densify = (mean_grad_ndc > opt.densify_grad_threshold) & (grad_count > 0);
  {
    const torch::Tensor seen = mean_grad_ndc.index({grad_count > 0});
    if (seen.numel() > 0) {
      const torch::Tensor q = torch::quantile(seen, torch::tensor({0.5f, 0.9f, 0.99f}, Float()));
      DYPHO_LOG(Debug) << "densify: mean |grad2d| median " << q[0].item<float>() << ", p90 " << q[1].item<float>()
                       << ", p99 " << q[2].item<float>() << "; over threshold: " << densify.sum().item<int64_t>();
    }
  }
  const int64_t budget = std::max<int64_t>(0, opt.max_gaussians - n);
  int64_t count = densify.sum().item<int64_t>();
  if (count > budget) {
    // Keep the largest gradients within the budget.
    const torch::Tensor scores = torch::where(densify, mean_grad_ndc, torch::full_like(mean_grad_ndc, -1.0f));
    densify = torch::zeros_like(densify);
    if (budget > 0) densify.index_put_({std::get<1>(scores.topk(budget))}, true);
    count = budget;
  }
  const torch::Tensor clone = densify & (max_scale <= opt.densify_size_threshold);
  const torch::Tensor split = densify & (max_scale > opt.densify_size_threshold);
  // Clones: copies with fresh optimiser state.
  const torch::Tensor ci = clone.nonzero().squeeze(1);
  const torch::Tensor si = split.nonzero().squeeze(1);
  std::vector<torch::Tensor> new_means, new_ls, new_q, new_op, new_dc, new_rest, new_anchor;
  auto take = [&](const torch::Tensor& idx) {
    new_ls.push_back(log_scales.value.index({idx}));
    new_q.push_back(quats.value.index({idx}));
    new_op.push_back(opacity.value.index({idx}));
    new_dc.push_back(sh_dc.value.index({idx}));
    new_rest.push_back(sh_rest.value.index({idx}));
    new_anchor.push_back(anchor.index({idx}));
  };
  if (ci.numel() > 0) {
    new_means.push_back(means.value.index({ci}));
    take(ci);
  }
  torch::Tensor keep = torch::ones({n}, Options(torch::kBool));
  if (si.numel() > 0) {
    // Two samples from each split Gaussian, scales divided by 1.6 (Kerbl et al. 2023).
    const torch::Tensor rot = QuatToMatrix(quats.value.index({si}));
    const torch::Tensor scale = log_scales.value.index({si}).exp();
    for (int rep = 0; rep < 2; ++rep) {
      // Samples from the host's generator on any device (the same draws as on the CPU).
      const torch::Tensor noise = torch::randn(scale.sizes(), HostFloat()).to(device);
      const torch::Tensor offset = torch::bmm(rot, (noise * scale).unsqueeze(2)).squeeze(2);
      new_means.push_back(means.value.index({si}) + offset);
      take(si);
      new_ls.back() = new_ls.back() - std::log(1.6f);
    }
    keep.index_put_({si}, false);
  }
  const int64_t added = ci.numel() + 2 * si.numel();
  // Prune: transparent or oversized.
  keep &= torch::sigmoid(opacity.value) >= opt.prune_opacity;
  keep &= max_scale <= opt.prune_max_scale;
  keep &= torch::isfinite(means.value).all(1) & torch::isfinite(log_scales.value).all(1);
  const int64_t removed = n - keep.sum().item<int64_t>();
  SelectGaussians(keep);
  if (!new_means.empty()) {
    AppendGaussians(torch::cat(new_means), torch::cat(new_ls), torch::cat(new_q), torch::cat(new_op),
                    torch::cat(new_dc), torch::cat(new_rest), torch::cat(new_anchor));
  }
  grad_accum.zero_();
  grad_count.zero_();
  stats.densified += static_cast<int>(added);
  stats.pruned += static_cast<int>(removed - si.numel());  // split originals are replaced, not pruned
}

int Mapper::Impl::Carve(int min_votes, float margin_abs, float margin_rel) {
  torch::NoGradGuard no_grad;
  const int64_t n = size();
  if (n == 0 || keyframes.size() < 2) return 0;
  namespace F = torch::nn::functional;
  const torch::Tensor means_now = means.value.detach();
  torch::Tensor free_votes = torch::zeros({n}, Options(torch::kInt32));
  torch::Tensor seen_votes = torch::zeros({n}, Options(torch::kInt32));
  const int64_t h = train_camera.height, w = train_camera.width;
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const Keyframe& kf = keyframes[k];
    const Rigid3d pose = PoseOf(kf);
    const Eigen::Matrix3f r = pose.rotation.toRotationMatrix().cast<float>();
    const torch::Tensor rt = ToDevice(torch::from_blob(const_cast<float*>(r.data()), {3, 3}, HostFloat()));  // R^T
    const torch::Tensor t = torch::tensor({static_cast<float>(pose.translation.x()),
                                           static_cast<float>(pose.translation.y()),
                                           static_cast<float>(pose.translation.z())},
                                          Float());
    const torch::Tensor pc = torch::matmul(means_now, rt) + t;
    const torch::Tensor z = pc.select(1, 2);
    const torch::Tensor zs = z.clamp_min(1e-6);
    const torch::Tensor u = torch::round(train_camera.fx * pc.select(1, 0) / zs + train_camera.cx);
    const torch::Tensor v = torch::round(train_camera.fy * pc.select(1, 1) / zs + train_camera.cy);
    const torch::Tensor inside = (z > opt.min_depth) & (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1);
    const torch::Tensor idx = (v.clamp(0, h - 1) * w + u.clamp(0, w - 1)).to(torch::kInt64);
    // Nearest valid depth of each 3x3 neighbourhood (invalid = far away).
    const torch::Tensor depth =
        torch::where(kf.train.depth_w > 0.5, kf.train.depth, torch::full_like(kf.train.depth, 1e6));
    const torch::Tensor nearest =
        (-F::max_pool2d((-depth).view({1, 1, h, w}), F::MaxPool2dFuncOptions(3).stride(1).padding(1))).view({-1});
    const torch::Tensor d = nearest.index({idx});
    const torch::Tensor observed = inside & (d < 1e5);
    const torch::Tensor stat = kf.train.static_w.view({-1}).index({idx}) > 0.5;
    const torch::Tensor margin = margin_abs + margin_rel * z;
    const torch::Tensor own = anchor == static_cast<int64_t>(k);
    free_votes += (observed & stat & ~own & (d > z + margin)).to(torch::kInt32);
    const torch::Tensor centre = kf.train.depth.view({-1}).index({idx});
    seen_votes += (inside & ((centre - z).abs() < margin)).to(torch::kInt32);
  }
  const torch::Tensor remove = (free_votes >= min_votes) & (free_votes > seen_votes);
  const int removed = static_cast<int>(remove.sum().item<int64_t>());
  if (removed > 0) SelectGaussians(~remove);
  stats.carved += removed;
  stats.num_gaussians = static_cast<int>(size());
  return removed;
}

}  // namespace dypho
