// The CUDA rasterizer: input checks, the forward state, and the order of the
// stages (raster_stages.cuh). Every pointer in the parameter, output and
// gradient structs is a device pointer.
//
// Memory (N Gaussians, P pairs, H x W pixels):
// - kept in the state from Forward to Backward: 50 bytes per Gaussian
//   (status, clamped bits, 3 float4), 4 bytes per pair (sorted ids), 8 bytes
//   per tile (ranges), 24 bytes per pixel;
// - Forward temporaries: 32 bytes per Gaussian (tile rectangle, counts, pair
//   ends) and 20 bytes per pair (keys and their sort buffers, the second id
//   buffer) plus CUB's scratch;
// - Backward temporaries: 40 bytes per Gaussian (screen-space gradients).
#include <climits>
#include <sstream>

#include "kernels/cuda/cuda_check.cuh"
#include "kernels/cuda/cuda_rasterizer.h"
#include "kernels/cuda/raster_stages.cuh"

namespace dypho::kernels::cuda {
namespace {

// Launched by nobody: CudaDeviceAvailable asks the runtime whether this
// library holds code the device can run.
__global__ void ProbeKernel() {}

class CudaState : public RasterState {
 public:
  RasterStats stats() const override { return stats_; }

  RasterStats stats_;
  CompositeMode mode_ = CompositeMode::kSorted;
  CameraData cam_{};
  int sh_coeffs_ = 1;
  float background_[3] = {0.f, 0.f, 0.f};
  // Per Gaussian [N] (see ProjectedArrays).
  DeviceArray<uint8_t> status_, clamped_;
  DeviceArray<float4> geom_, conic_, color_;
  // Tile bins.
  DeviceArray<int32_t> sorted_ids_;  // [P]
  DeviceArray<int2> tile_ranges_;    // [tiles]
  // Per pixel (see PixelState): sorted mode uses num_contrib_, order-independent mode sum_weight_.
  DeviceArray<float> transmittance_, color_out_, depth_out_, sum_weight_;
  DeviceArray<int32_t> num_contrib_;

  PixelState pixels() const {
    PixelState p;
    p.transmittance = const_cast<float*>(transmittance_.data());
    p.num_contrib = const_cast<int32_t*>(num_contrib_.data());
    p.color = const_cast<float*>(color_out_.data());
    p.depth = const_cast<float*>(depth_out_.data());
    p.sum_weight = const_cast<float*>(sum_weight_.data());
    return p;
  }
};

class CudaRasterizer : public Rasterizer {
 public:
  Backend backend() const override { return Backend::kCuda; }

  std::unique_ptr<RasterState> Forward(const GaussianParams& params, const RasterCamera& camera,
                                       const RasterSettings& settings, const RasterOutputs& outputs) override {
    ValidateRasterInputs(params, camera, settings);
    DYPHO_CHECK_INPUT(outputs.color && outputs.depth && outputs.alpha)
        << "rasterizer outputs: color, depth and alpha buffers are required";

    auto st = std::make_unique<CudaState>();
    st->mode_ = settings.mode;
    st->cam_ = math::MakeCameraData<float>(camera, settings, params.sh_coeffs);
    st->sh_coeffs_ = params.sh_coeffs;
    for (int c = 0; c < 3; ++c) st->background_[c] = settings.background[c];
    const CameraData& cam = st->cam_;
    const int n = params.num_gaussians;
    const size_t pixels = static_cast<size_t>(camera.width) * camera.height;

    // 1. Projection.
    st->status_.Resize(n);
    st->clamped_.Resize(n);
    st->geom_.Resize(n);
    st->conic_.Resize(n);
    st->color_.Resize(n);
    DeviceArray<int4> tile_rect(n);
    DeviceArray<unsigned long long> counters(kNumForwardCounters);
    counters.Zero();
    ProjectedArrays projected;
    projected.status = st->status_.data();
    projected.clamped = st->clamped_.data();
    projected.geom = st->geom_.data();
    projected.conic = st->conic_.data();
    projected.color = st->color_.data();
    projected.tile_rect = tile_rect.data();
    ProjectForward(params, cam, projected, outputs.radii, counters.data());

    // 2. Pairs per Gaussian and their prefix sum; the host needs the total
    // to size the pair buffers (the one synchronisation of the pass).
    DeviceArray<int64_t> pair_ends;
    CountTilePairs(n, cam, tile_rect.data(), st->geom_.data(), st->conic_.data(), &pair_ends);
    if (n > 0) {
      DYPHO_CUDA_CHECK(cudaMemcpyAsync(counters.data() + kCountPairs, pair_ends.data() + (n - 1), sizeof(int64_t),
                                       cudaMemcpyDeviceToDevice, 0));
    }
    unsigned long long host_counters[kNumForwardCounters] = {};
    CopyToHost(host_counters, counters.data(), sizeof(host_counters));
    const int64_t num_pairs = static_cast<int64_t>(host_counters[kCountPairs]);
    st->stats_.num_gaussians = n;
    st->stats_.num_visible = static_cast<int>(host_counters[kCountVisible]);
    st->stats_.num_nonfinite = static_cast<int>(host_counters[kCountNonFinite]);
    st->stats_.num_tile_pairs = num_pairs;
    DYPHO_CHECK_INPUT(num_pairs <= INT_MAX)
        << "CUDA rasterizer: " << num_pairs << " (Gaussian, tile) pairs exceed the limit of " << INT_MAX
        << "; render fewer or smaller Gaussians, or a smaller image";

    // 3. Sorted tile lists.
    BinTilePairs(n, static_cast<int>(num_pairs), cam, tile_rect.data(), st->geom_.data(), st->conic_.data(),
                 pair_ends.data(), settings.mode == CompositeMode::kSorted, &st->sorted_ids_, &st->tile_ranges_);

    // 4. Compositing.
    st->transmittance_.Resize(pixels);
    st->color_out_.Resize(3 * pixels);
    st->depth_out_.Resize(pixels);
    if (settings.mode == CompositeMode::kSorted) {
      st->num_contrib_.Resize(pixels);
    } else {
      st->sum_weight_.Resize(pixels);
    }
    RasterizeForward(settings.mode, cam, st->background_, st->tile_ranges_.data(), st->sorted_ids_.data(),
                     st->geom_.data(), st->conic_.data(), st->color_.data(), outputs, st->pixels());
    return st;
  }

  void Backward(const RasterState& state, const GaussianParams& params, const RasterCamera& camera,
                const RasterSettings& settings, const RasterOutputGrads& output_grads,
                const GaussianGrads& grads) override {
    const auto* st = dynamic_cast<const CudaState*>(&state);
    DYPHO_CHECK_INPUT(st != nullptr) << "rasterizer backward: the state does not come from the CUDA backend";
    ValidateRasterInputs(params, camera, settings);
    DYPHO_CHECK_INPUT(st->stats_.num_gaussians == params.num_gaussians)
        << "rasterizer backward: " << params.num_gaussians << " Gaussians given, forward saw "
        << st->stats_.num_gaussians;
    DYPHO_CHECK_INPUT(st->sh_coeffs_ == params.sh_coeffs)
        << "rasterizer backward: sh_coeffs " << params.sh_coeffs << " given, forward saw " << st->sh_coeffs_;
    DYPHO_CHECK_INPUT(st->mode_ == settings.mode) << "rasterizer backward: compositing mode differs from forward";
    DYPHO_CHECK_INPUT(st->cam_.width == camera.width && st->cam_.height == camera.height)
        << "rasterizer backward: image size differs from forward";
    const int n = params.num_gaussians;

    // 5. Screen-space gradients per Gaussian.
    DeviceArray<float> screen_grads(static_cast<size_t>(kScreenGradSize) * n);
    screen_grads.Zero();
    if (st->stats_.num_tile_pairs > 0) {
      RasterizeBackward(st->mode_, st->cam_, st->background_, st->tile_ranges_.data(), st->sorted_ids_.data(),
                        st->geom_.data(), st->conic_.data(), st->color_.data(), st->pixels(), output_grads,
                        screen_grads.data());
    }
    // 6. Back to the parameters and the pose.
    ProjectBackward(params, st->cam_, st->status_.data(), st->clamped_.data(), screen_grads.data(), grads);
  }
};

}  // namespace

bool CudaDeviceAvailable(std::string* why) {
  int count = 0;
  cudaError_t error = cudaGetDeviceCount(&count);
  if (error == cudaSuccess && count == 0) {
    if (why) *why = "no CUDA device: the CUDA runtime reports 0 devices";
    return false;
  }
  if (error == cudaSuccess) {
    // Is there code for this device (SASS for its architecture or PTX the
    // driver can compile)?
    cudaFuncAttributes attributes;
    error = cudaFuncGetAttributes(&attributes, ProbeKernel);
  }
  if (error != cudaSuccess) {
    cudaGetLastError();  // clear a non-sticky error so later checks do not report it
    if (why) {
      std::ostringstream msg;
      msg << "no CUDA device: " << cudaGetErrorString(error) << " (" << cudaGetErrorName(error) << ")";
      *why = msg.str();
    }
    return false;
  }
  return true;
}

std::unique_ptr<Rasterizer> CreateCudaRasterizer() { return std::make_unique<CudaRasterizer>(); }

}  // namespace dypho::kernels::cuda
