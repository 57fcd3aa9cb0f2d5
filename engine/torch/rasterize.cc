#include "engine/torch/rasterize.h"

#include <ATen/ATen.h>
#include <c10/core/DeviceGuard.h>
#include <torch/csrc/autograd/custom_function.h>

#include <Eigen/Core>
#include <climits>
#include <cmath>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "common/check.h"
#include "common/rigid3.h"
#include "kernels/cpu/cpu_rasterizer.h"

namespace dypho {
namespace {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// Indices of the tensor inputs of RasterizeFunction::forward (they come first,
// so they are also the autograd edge indices used by needs_input_grad).
enum Input : size_t { kMeans, kLogScales, kQuats, kOpacity, kSh, kTwist, kProbe };

// What the forward keeps for the backward. Owned by the autograd node through
// an IValue capsule in ctx->saved_data; freed with the graph.
struct RasterStateHolder : torch::CustomClassHolder {
  std::unique_ptr<kernels::Rasterizer> rasterizer;  // null on the float64 CPU path
  std::unique_ptr<kernels::RasterState> state;
  kernels::RasterCamera camera;  // the camera rendered (twist applied)
  kernels::RasterSettings settings;
};

const char* DtypeName(c10::ScalarType type) {
  switch (type) {
    case torch::kFloat32: return "float32";
    case torch::kFloat64: return "float64";
    case torch::kFloat16: return "float16";
    case torch::kBFloat16: return "bfloat16";
    case torch::kInt32: return "int32";
    case torch::kInt64: return "int64";
    default: return c10::toString(type);
  }
}

std::string ShapeString(const torch::Tensor& t) {
  std::ostringstream s;
  s << "[";
  for (int64_t d = 0; d < t.dim(); ++d) s << (d ? ", " : "") << t.size(d);
  s << "]";
  return s.str();
}

// Checks dtype and device against `means`, and the shape: `shape` holds the
// expected sizes with -1 for "any"; `shape_text` is what the message shows.
void CheckLike(const torch::Tensor& t, const char* name, const torch::Tensor& means,
               const std::vector<int64_t>& shape, const char* shape_text) {
  DYPHO_CHECK_INPUT(t.defined()) << "RasterizeGaussians: `" << name << "` is an undefined tensor (expected "
                                 << shape_text << ")";
  DYPHO_CHECK_INPUT(t.scalar_type() == means.scalar_type())
      << "RasterizeGaussians: `" << name << "` has dtype " << DtypeName(t.scalar_type()) << " but `means` has "
      << DtypeName(means.scalar_type()) << "; all inputs must share one dtype";
  DYPHO_CHECK_INPUT(t.device() == means.device())
      << "RasterizeGaussians: `" << name << "` is on device " << t.device().str() << " but `means` is on "
      << means.device().str() << "; all inputs must be on one device";
  bool ok = t.dim() == static_cast<int64_t>(shape.size());
  for (size_t d = 0; ok && d < shape.size(); ++d) ok = shape[d] < 0 || t.size(d) == shape[d];
  DYPHO_CHECK_INPUT(ok) << "RasterizeGaussians: `" << name << "` must have shape " << shape_text << " (got "
                        << ShapeString(t) << ")";
}

// Left Jacobian of SE(3) for the twist (rho, phi): Exp(xi + d) ~ Exp(J d) Exp(xi).
//   J = sum_n ad(xi)^n / (n + 1)!,  ad(xi) = [[phi^, rho^], [0, phi^]].
// The series is entire; summed until the terms vanish, it is exact to
// rounding for any rotation angle below a few pi (what a pose correction is).
Matrix6d Se3LeftJacobian(const Vector6d& xi) {
  auto hat = [](const Eigen::Vector3d& v) {
    Eigen::Matrix3d m;
    m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return m;
  };
  Matrix6d ad = Matrix6d::Zero();
  ad.topLeftCorner<3, 3>() = hat(xi.tail<3>());
  ad.topRightCorner<3, 3>() = hat(xi.head<3>());
  ad.bottomRightCorner<3, 3>() = hat(xi.tail<3>());
  Matrix6d jac = Matrix6d::Identity();
  Matrix6d term = Matrix6d::Identity();
  for (int n = 1; n < 200; ++n) {
    term = term * ad / static_cast<double>(n + 1);
    jac += term;
    if (term.cwiseAbs().maxCoeff() <= 1e-18 * jac.cwiseAbs().maxCoeff()) break;
  }
  return jac;
}

// cam_from_world' = Exp(xi) * cam_from_world on the row-major 3x4 matrix
// (composed as matrices so the given rotation is not re-orthonormalised).
void ApplyTwist(const Vector6d& xi, kernels::RasterCamera* camera) {
  const Eigen::Matrix<double, 3, 4> delta = Rigid3d::Exp(xi).ToMatrix();
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) pose(r, c) = camera->cam_from_world[4 * r + c];
  }
  const Eigen::Matrix<double, 3, 4> out = delta.leftCols<3>() * pose.topRows<3>() +
                                          delta.col(3) * Eigen::RowVector4d(0, 0, 0, 1);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) camera->cam_from_world[4 * r + c] = out(r, c);
  }
}

template <typename T>
const T* DataOrNull(const torch::Tensor& t) {
  return t.defined() && t.numel() > 0 ? t.data_ptr<T>() : nullptr;
}
template <typename T>
T* MutableDataOrNull(const torch::Tensor& t) {
  return t.defined() && t.numel() > 0 ? t.data_ptr<T>() : nullptr;
}

template <typename T>
kernels::GaussianParamsT<T> ParamsView(const torch::Tensor& means, const torch::Tensor& log_scales,
                                       const torch::Tensor& quats, const torch::Tensor& opacity,
                                       const torch::Tensor& sh) {
  kernels::GaussianParamsT<T> p;
  p.means = DataOrNull<T>(means);
  p.log_scales = DataOrNull<T>(log_scales);
  p.quats = DataOrNull<T>(quats);
  p.opacity_logits = DataOrNull<T>(opacity);
  p.sh = DataOrNull<T>(sh);
  p.num_gaussians = static_cast<int>(means.size(0));
  p.sh_coeffs = static_cast<int>(sh.size(1));
  return p;
}

// An incoming output gradient, contiguous in the forward's dtype, or undefined.
torch::Tensor GradOrUndefined(const torch::Tensor& g, c10::ScalarType type) {
  return g.defined() ? g.to(type).contiguous() : torch::Tensor();
}

class RasterizeFunction : public torch::autograd::Function<RasterizeFunction> {
 public:
  static variable_list forward(AutogradContext* ctx, const torch::Tensor& means, const torch::Tensor& log_scales,
                               const torch::Tensor& quats, const torch::Tensor& opacity_logits,
                               const torch::Tensor& sh, const torch::Tensor& cam_twist,
                               const torch::Tensor& probe, const kernels::RasterCamera& camera,
                               const kernels::RasterSettings& settings) {
    const int64_t n = means.size(0);
    const torch::Tensor m = means.contiguous();
    const torch::Tensor ls = log_scales.contiguous();
    const torch::Tensor q = quats.contiguous();
    const torch::Tensor op = opacity_logits.reshape({n}).contiguous();
    const torch::Tensor s = sh.contiguous();

    auto holder = c10::make_intrusive<RasterStateHolder>();
    holder->camera = camera;
    holder->settings = settings;

    // The twist is read on the host (6 values; on CUDA one small synchronising
    // copy per render) to build the rendered camera, and its left Jacobian for
    // the backward is moved to the tensors' device here, once.
    const torch::Tensor xi_host = cam_twist.detach().to(torch::kCPU, torch::kFloat64).contiguous();
    Vector6d xi;
    for (int j = 0; j < 6; ++j) xi[j] = xi_host.data_ptr<double>()[j];
    DYPHO_CHECK_INPUT(xi.allFinite()) << "RasterizeGaussians: `cam_twist` has a non-finite value";
    torch::Tensor jac_t;  // J_l(xi)^T [6, 6]; undefined when xi = 0 (J = I)
    if (!xi.isZero(0.0)) {
      ApplyTwist(xi, &holder->camera);
      const Matrix6d jac = Se3LeftJacobian(xi);
      auto host = torch::empty({6, 6}, torch::TensorOptions().dtype(torch::kFloat64));
      double* dst = host.data_ptr<double>();
      for (int r = 0; r < 6; ++r) {
        for (int c = 0; c < 6; ++c) dst[6 * r + c] = jac(c, r);  // transposed
      }
      jac_t = host.to(m.device(), m.scalar_type());
    }

    const auto opts = m.options();
    const int64_t h = holder->camera.height, w = holder->camera.width;
    torch::Tensor color = torch::empty({h, w, 3}, opts);
    torch::Tensor depth = torch::empty({h, w}, opts);
    torch::Tensor alpha = torch::empty({h, w}, opts);
    torch::Tensor radii = torch::empty({n}, opts.dtype(torch::kInt32));

    if (m.scalar_type() == torch::kFloat64) {
      kernels::RasterOutputsT<double> out{color.data_ptr<double>(), depth.data_ptr<double>(),
                                          alpha.data_ptr<double>(), MutableDataOrNull<int32_t>(radii)};
      holder->state = kernels::cpu::Forward<double>(ParamsView<double>(m, ls, q, op, s), holder->camera,
                                                    holder->settings, out);
    } else {
      holder->rasterizer =
          kernels::CreateRasterizer(m.is_cuda() ? kernels::Backend::kCuda : kernels::Backend::kCpu);
      kernels::RasterOutputs out{color.data_ptr<float>(), depth.data_ptr<float>(), alpha.data_ptr<float>(),
                                 MutableDataOrNull<int32_t>(radii)};
      holder->state = holder->rasterizer->Forward(ParamsView<float>(m, ls, q, op, s), holder->camera,
                                                  holder->settings, out);
    }

    ctx->save_for_backward({m, ls, q, op, s, jac_t});
    ctx->saved_data["state"] = c10::IValue::make_capsule(std::move(holder));
    ctx->saved_data["opacity_sizes"] = opacity_logits.sizes().vec();
    ctx->mark_non_differentiable({radii});
    ctx->set_materialize_grads(false);  // unused outputs reach backward as undefined (null cotangent)
    return {color, depth, alpha, radii};
  }

  static variable_list backward(AutogradContext* ctx, variable_list grad_outputs) {
    const variable_list saved = ctx->get_saved_variables();
    const torch::Tensor &m = saved[0], &ls = saved[1], &q = saved[2], &op = saved[3], &s = saved[4];
    const torch::Tensor& jac_t = saved[5];
    const c10::intrusive_ptr<torch::CustomClassHolder> capsule = ctx->saved_data.at("state").toCapsule();
    const auto* holder = dynamic_cast<const RasterStateHolder*>(capsule.get());
    DYPHO_CHECK(holder != nullptr && holder->state != nullptr) << "RasterizeGaussians backward: state lost";

    const auto type = m.scalar_type();
    const torch::Tensor v_color = GradOrUndefined(grad_outputs[0], type);
    const torch::Tensor v_depth = GradOrUndefined(grad_outputs[1], type);
    const torch::Tensor v_alpha = GradOrUndefined(grad_outputs[2], type);

    auto alloc_if = [&](Input input, const torch::Tensor& like) {
      return ctx->needs_input_grad(input) ? torch::empty_like(like, torch::MemoryFormat::Contiguous)
                                          : torch::Tensor();
    };
    torch::Tensor v_means = alloc_if(kMeans, m);
    torch::Tensor v_log_scales = alloc_if(kLogScales, ls);
    torch::Tensor v_quats = alloc_if(kQuats, q);
    torch::Tensor v_opacity = alloc_if(kOpacity, op);
    torch::Tensor v_sh = alloc_if(kSh, s);
    torch::Tensor v_twist = ctx->needs_input_grad(kTwist) ? torch::empty({6}, m.options()) : torch::Tensor();
    torch::Tensor v_probe = alloc_if(kProbe, op);

    c10::OptionalDeviceGuard device_guard;
    if (m.is_cuda()) device_guard.reset_device(m.device());
    if (type == torch::kFloat64) {
      const kernels::RasterOutputGradsT<double> og{DataOrNull<double>(v_color), DataOrNull<double>(v_depth),
                                                   DataOrNull<double>(v_alpha)};
      const kernels::GaussianGradsT<double> gg{
          MutableDataOrNull<double>(v_means),   MutableDataOrNull<double>(v_log_scales),
          MutableDataOrNull<double>(v_quats),   MutableDataOrNull<double>(v_opacity),
          MutableDataOrNull<double>(v_sh),      MutableDataOrNull<double>(v_twist),
          MutableDataOrNull<double>(v_probe)};
      kernels::cpu::Backward<double>(*holder->state, ParamsView<double>(m, ls, q, op, s), holder->camera,
                                     holder->settings, og, gg);
    } else {
      DYPHO_CHECK(holder->rasterizer != nullptr) << "RasterizeGaussians backward: rasterizer lost";
      const kernels::RasterOutputGrads og{DataOrNull<float>(v_color), DataOrNull<float>(v_depth),
                                          DataOrNull<float>(v_alpha)};
      const kernels::GaussianGrads gg{MutableDataOrNull<float>(v_means),   MutableDataOrNull<float>(v_log_scales),
                                      MutableDataOrNull<float>(v_quats),   MutableDataOrNull<float>(v_opacity),
                                      MutableDataOrNull<float>(v_sh),      MutableDataOrNull<float>(v_twist),
                                      MutableDataOrNull<float>(v_probe)};
      holder->rasterizer->Backward(*holder->state, ParamsView<float>(m, ls, q, op, s), holder->camera,
                                   holder->settings, og, gg);
    }

    if (v_opacity.defined()) v_opacity = v_opacity.reshape(ctx->saved_data.at("opacity_sizes").toIntVector());
    // Kernel: dL/d delta for Exp(delta) * cam_from_world'. Chain to xi: J_l(xi)^T.
    if (v_twist.defined() && jac_t.defined()) v_twist = torch::matmul(jac_t, v_twist);
    return {v_means, v_log_scales, v_quats, v_opacity, v_sh, v_twist, v_probe, torch::Tensor(), torch::Tensor()};
  }
};

}  // namespace

RasterizeResult RasterizeGaussians(const torch::Tensor& means, const torch::Tensor& log_scales,
                                   const torch::Tensor& quats, const torch::Tensor& opacity_logits,
                                   const torch::Tensor& sh, const torch::Tensor& cam_twist,
                                   const kernels::RasterCamera& camera, const kernels::RasterSettings& settings,
                                   const torch::Tensor& mean2d_abs_probe) {
  // `means` fixes the dtype, the device and N; every other tensor must agree.
  DYPHO_CHECK_INPUT(means.defined()) << "RasterizeGaussians: `means` is an undefined tensor (expected [N, 3])";
  const auto type = means.scalar_type();
  DYPHO_CHECK_INPUT(type == torch::kFloat32 || type == torch::kFloat64)
      << "RasterizeGaussians: `means` has dtype " << DtypeName(type)
      << "; expected float32 (or float64 on the CPU)";
  DYPHO_CHECK_INPUT(means.is_cpu() || means.is_cuda())
      << "RasterizeGaussians: `means` is on device " << means.device().str() << "; expected cpu or cuda";
  DYPHO_CHECK_INPUT(!(means.is_cuda() && type == torch::kFloat64))
      << "RasterizeGaussians: `means` is float64 on " << means.device().str()
      << "; float64 is supported on the CPU only (use float32 on CUDA)";
  DYPHO_CHECK_INPUT(means.dim() == 2 && means.size(1) == 3)
      << "RasterizeGaussians: `means` must have shape [N, 3] (got " << ShapeString(means) << ")";
  const int64_t n = means.size(0);
  DYPHO_CHECK_INPUT(n <= INT_MAX) << "RasterizeGaussians: " << n << " Gaussians exceed the kernels' limit "
                                  << INT_MAX;
  CheckLike(log_scales, "log_scales", means, {n, 3}, "[N, 3]");
  CheckLike(quats, "quats", means, {n, 4}, "[N, 4]");
  if (opacity_logits.defined() && opacity_logits.dim() == 2) {
    CheckLike(opacity_logits, "opacity_logits", means, {n, 1}, "[N] or [N, 1]");
  } else {
    CheckLike(opacity_logits, "opacity_logits", means, {n}, "[N] or [N, 1]");
  }
  CheckLike(sh, "sh", means, {n, -1, 3}, "[N, K, 3] with K in {1, 4, 9, 16}");
  const int64_t k = sh.size(1);
  DYPHO_CHECK_INPUT(k == 1 || k == 4 || k == 9 || k == 16)
      << "RasterizeGaussians: `sh` must have shape [N, K, 3] with K in {1, 4, 9, 16} (got " << ShapeString(sh)
      << ")";
  const torch::Tensor twist = cam_twist.defined() ? cam_twist : torch::zeros({6}, means.options());
  CheckLike(twist, "cam_twist", means, {6}, "[6]");
  // Autograd needs a defined tensor in every tensor slot: an empty stand-in
  // (never read, never given a gradient) when no probe is wanted.
  const torch::Tensor probe =
      mean2d_abs_probe.defined() ? mean2d_abs_probe : torch::empty({0}, means.options());
  if (mean2d_abs_probe.defined()) CheckLike(probe, "mean2d_abs_probe", means, {n}, "[N]");
  // Camera and settings first, so a bad image size is reported as such and
  // not as an allocation failure.
  kernels::ValidateRasterInputs(static_cast<int>(n), static_cast<int>(k), true, camera, settings);

  c10::OptionalDeviceGuard device_guard;
  if (means.is_cuda()) device_guard.reset_device(means.device());
  const variable_list out = RasterizeFunction::apply(means, log_scales, quats, opacity_logits, sh, twist, probe,
                                                     camera, settings);
  return RasterizeResult{out[0], out[1], out[2], out[3]};
}

torch::Tensor MakeMean2dAbsProbe(const torch::Tensor& means) {
  DYPHO_CHECK_INPUT(means.defined() && means.dim() == 2 && means.size(1) == 3)
      << "MakeMean2dAbsProbe: `means` must have shape [N, 3] (got "
      << (means.defined() ? ShapeString(means) : std::string("undefined")) << ")";
  return torch::zeros({means.size(0)}, means.options().requires_grad(true));
}

}  // namespace dypho
