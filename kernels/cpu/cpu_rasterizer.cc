#include "kernels/cpu/cpu_rasterizer.h"

#include <memory>

#include "common/files.h"

namespace dypho::kernels::cpu {
namespace {

class CpuRasterizer : public Rasterizer {
 public:
  Backend backend() const override { return Backend::kCpu; }
  std::unique_ptr<RasterState> Forward(const GaussianParams& params, const RasterCamera& camera,
                                       const RasterSettings& settings, const RasterOutputs& outputs) override {
    return cpu::Forward<float>(params, camera, settings, outputs);
  }
  void Backward(const RasterState& state, const GaussianParams& params, const RasterCamera& camera,
                const RasterSettings& settings, const RasterOutputGrads& output_grads,
                const GaussianGrads& grads) override {
    cpu::Backward<float>(state, params, camera, settings, output_grads, grads);
  }
};

}  // namespace

std::unique_ptr<Rasterizer> CreateCpuRasterizer() {
  KeepFreedMemory();
  return std::make_unique<CpuRasterizer>();
}

}  // namespace dypho::kernels::cpu
