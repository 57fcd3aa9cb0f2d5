// MapperOptions::Validate (engine/map/mapper.h): no LibTorch needed.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "common/check.h"
#include "common/files.h"
#include "engine/map/mapper.h"

namespace dypho {

void MapperOptions::Validate() const {
  sensor.Validate();
  auto positive = [](float v, const char* name) {
    DYPHO_CHECK_INPUT(std::isfinite(v) && v > 0) << "mapper option " << name << " must be > 0 (got " << v << ")";
  };
  auto non_negative = [](float v, const char* name) {
    DYPHO_CHECK_INPUT(std::isfinite(v) && v >= 0) << "mapper option " << name << " must be >= 0 (got " << v << ")";
  };
  auto unit = [](float v, const char* name, bool open) {
    DYPHO_CHECK_INPUT(std::isfinite(v) && (open ? (v > 0 && v < 1) : (v >= 0 && v <= 1)))
        << "mapper option " << name << " must be in " << (open ? "(0, 1)" : "[0, 1]") << " (got " << v << ")";
  };
  DYPHO_CHECK_INPUT(train_downscale >= 1 && train_downscale <= 8)
      << "mapper option train_downscale must be in [1, 8] (got " << train_downscale << ")";
  DYPHO_CHECK_INPUT(refine_downscale >= 0 && refine_downscale <= 8)
      << "mapper option refine_downscale must be in [0, 8] (got " << refine_downscale << ")";
  DYPHO_CHECK_INPUT(sh_degree >= 0 && sh_degree <= 3) << "mapper option sh_degree must be in [0, 3] (got " << sh_degree << ")";
  unit(background, "background", false);
  DYPHO_CHECK_INPUT(insert_stride >= 1 && insert_stride <= 64)
      << "mapper option insert_stride must be in [1, 64] (got " << insert_stride << ")";
  unit(insert_alpha, "insert_alpha", false);
  non_negative(insert_depth_ratio, "insert_depth_ratio");
  positive(insert_scale_factor, "insert_scale_factor");
  unit(insert_opacity, "insert_opacity", true);
  positive(min_depth, "min_depth");
  DYPHO_CHECK_INPUT(std::isfinite(max_depth) && max_depth > min_depth)
      << "mapper option max_depth must be > min_depth (got " << max_depth << ")";
  unit(lambda_ssim, "lambda_ssim", false);
  non_negative(depth_weight, "depth_weight");
  DYPHO_CHECK_INPUT(window_size >= 1) << "mapper option window_size must be >= 1 (got " << window_size << ")";
  unit(older_keyframe_prob, "older_keyframe_prob", false);
  DYPHO_CHECK_INPUT(std::isfinite(sharp_sampling_floor) && sharp_sampling_floor > 0 && sharp_sampling_floor <= 1)
      << "mapper option sharp_sampling_floor must be in (0, 1] (got " << sharp_sampling_floor << ")";
  for (auto [v, name] : {std::pair{lr_means, "lr_means"}, {lr_log_scales, "lr_log_scales"}, {lr_quats, "lr_quats"},
                         {lr_opacity, "lr_opacity"}, {lr_sh_dc, "lr_sh_dc"}, {lr_sh_rest, "lr_sh_rest"},
                         {lr_pose_rotation, "lr_pose_rotation"}, {lr_pose_translation, "lr_pose_translation"}}) {
    non_negative(v, name);
  }
  DYPHO_CHECK_INPUT(densify_every >= 0) << "mapper option densify_every must be >= 0 (got " << densify_every << ")";
  positive(densify_grad_threshold, "densify_grad_threshold");
  positive(densify_size_threshold, "densify_size_threshold");
  DYPHO_CHECK_INPUT(max_gaussians >= 1) << "mapper option max_gaussians must be >= 1 (got " << max_gaussians << ")";
  unit(prune_opacity, "prune_opacity", false);
  positive(prune_max_scale, "prune_max_scale");
  DYPHO_CHECK_INPUT(num_threads >= 0 && num_threads <= kMaxThreads)
      << "mapper option num_threads must be in [0, " << kMaxThreads << "] (got " << num_threads << ")";
  DYPHO_CHECK_INPUT(IsMapperDevice(device))
      << "mapper option device must be cpu, cuda or cuda:N with N a GPU index, 0 to 99 (got '" << device << "')";
}

bool IsMapperDevice(const std::string& device) {
  if (device == "cpu" || device == "cuda") return true;
  // "cuda:N", N in [0, 99] without a leading zero.
  if (device.rfind("cuda:", 0) != 0) return false;
  const std::string n = device.substr(5);
  if (n.empty() || n.size() > 2 || (n.size() == 2 && n[0] == '0')) return false;
  return std::all_of(n.begin(), n.end(), [](char c) { return c >= '0' && c <= '9'; });
}

}  // namespace dypho
