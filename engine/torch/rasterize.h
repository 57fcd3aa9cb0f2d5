// LibTorch front end of the differentiable Gaussian rasterizer: a
// torch::autograd::Function around kernels::Rasterizer, so that a loss built
// from LibTorch ops backpropagates to the Gaussian parameters and to a pose
// perturbation. LibTorch headers are only included under engine/torch/.
//
// Inputs (one dtype and one device for all tensors; any strides: they are
// made contiguous before the kernels see them):
//   means           [N, 3]        world coordinates
//   log_scales      [N, 3]        log of the standard deviations
//   quats           [N, 4]        w, x, y, z (normalised inside)
//   opacity_logits  [N] or [N, 1] opacity = sigmoid(logit)
//   sh              [N, K, 3]     K = 1, 4, 9 or 16 SH coefficients per channel
//   cam_twist       [6]           (rho, phi); may be an undefined tensor (= zeros)
// Conventions (camera, compositing, culling) are those of kernels/rasterizer.h.
//
// Backends: float32 CUDA tensors run the CUDA backend (it takes device
// pointers), float32 CPU tensors the CPU backend, both created with
// kernels::CreateRasterizer. The kernels' interface takes no CUDA stream:
// render with LibTorch on its default stream (do not install another current
// stream around these calls) so that LibTorch's ops and the kernels are ordered.
// float64 is accepted on the CPU only: it runs the double instantiation of the
// CPU reference (kernels::cpu::Forward<double>), meant for finite-difference
// gradient checks. Anything else throws dypho::InvalidInput naming the tensor,
// what was expected and what was found.
//
// Pose twist. The rendered camera is
//   cam_from_world' = Exp(xi) * camera.cam_from_world
// (Rigid3d::Exp, left perturbation, twist ordered (rho, phi)). The forward
// copies the 6 values of xi to the host to build that camera (a tiny copy, but
// on CUDA it synchronises once per render). The gradient returned for
// cam_twist is the exact dL/dxi at the given xi: the kernel's gradient with
// respect to a left perturbation of the rendered camera, g = dL/d delta at
// delta = 0 with Exp(delta) * cam_from_world', multiplied by J_l(xi)^T, the
// transposed left Jacobian of SE(3) (Exp(xi + d) ~ Exp(J_l(xi) d) Exp(xi)).
// At xi = 0, J_l = I and the kernel's gradient is returned unchanged. So xi can
// be optimised directly with any optimiser; folding it into the pose from time
// to time (pose = Exp(xi) * pose, xi = 0) keeps it small and is equivalent.
//
// Screen-space gradient for densification (the "probe" mechanism, after
// gsplat's absgrad trick): pass `mean2d_abs_probe`, a [N] tensor with
// requires_grad (MakeMean2dAbsProbe(means) makes one: zeros, same dtype and
// device). Its values are ignored; after backward, probe.grad() holds
// kernels::GaussianGrads::v_mean2d_abs, |dL/d mean2d| per Gaussian [loss units
// per pixel]. Like any .grad it accumulates: reuse one probe over several
// renders (views) to sum the statistic, zero it when the statistic is reset.
// It is NOT a derivative of the loss: leave it out of gradient checks and out
// of optimisers. Without a probe (undefined tensor) nothing extra is computed.
//
// The forward's kernels::RasterState (and the rasterizer that made it) is
// owned by the autograd graph: a holder derived from torch::CustomClassHolder
// in ctx->saved_data (an IValue capsule). It is freed with the graph.
// Backward is once-differentiable (no double backward).
//
// Threads: kernels::RasterSettings::num_threads drives the CPU kernels
// (0 = all hardware threads); LibTorch's own ops are configured separately
// with ConfigureTorchThreads (engine/torch/threads.h).
#pragma once

#include <torch/types.h>

#include "kernels/rasterizer.h"

namespace dypho {

struct RasterizeResult {
  torch::Tensor color;  // [H, W, 3] composited colour (with background)
  torch::Tensor depth;  // [H, W] expected camera z [m] (not normalised by alpha)
  torch::Tensor alpha;  // [H, W] accumulated opacity
  torch::Tensor radii;  // [N] int32 3-sigma radius [px], 0 = not drawn; not differentiable
};

// Renders the Gaussians seen by `camera` perturbed by `cam_twist` (see above).
// Throws dypho::InvalidInput for bad tensors, camera or settings.
RasterizeResult RasterizeGaussians(const torch::Tensor& means, const torch::Tensor& log_scales,
                                   const torch::Tensor& quats, const torch::Tensor& opacity_logits,
                                   const torch::Tensor& sh, const torch::Tensor& cam_twist,
                                   const kernels::RasterCamera& camera, const kernels::RasterSettings& settings,
                                   const torch::Tensor& mean2d_abs_probe = torch::Tensor());

// A probe for RasterizeGaussians: zeros [N] with the dtype and device of
// `means` [N, 3], requires_grad = true.
torch::Tensor MakeMean2dAbsProbe(const torch::Tensor& means);

}  // namespace dypho
