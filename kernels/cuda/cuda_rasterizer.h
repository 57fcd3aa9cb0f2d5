// CUDA backend of the differentiable Gaussian rasterizer: the plain C++ entry
// points (no CUDA types, so any C++ translation unit may include this header).
//
// The backend has the interface and the rendering definition of
// kernels/rasterizer.h and shares kernels/math with the CPU reference. Every
// pointer in GaussianParams, RasterOutputs, RasterOutputGrads and
// GaussianGrads handed to the CUDA rasterizer is a DEVICE pointer (memory from
// cudaMalloc, DeviceAlloc, or a CUDA tensor's data); RasterCamera and
// RasterSettings are host values. All work runs on the default stream; Forward
// synchronises once (to read the number of (Gaussian, tile) pairs), Backward
// not at all. Results are deterministic up to the order of floating-point
// atomic additions in the backward pass. RasterStats::num_evaluations is not
// counted (0). A CudaRasterizer holds no buffers between calls; each
// RasterState owns the device memory its Backward needs.
//
// Only compiled when the build has the CUDA backend (DYPHO_WITH_CUDA); callers
// outside kernels/ should go through kernels::CreateRasterizer and
// kernels::BackendAvailable instead of calling these directly.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "kernels/cuda/device_array.h"
#include "kernels/rasterizer.h"

namespace dypho::kernels::cuda {

// True when the CUDA runtime sees at least one device. Otherwise false, and
// `why` (when non-null) says "no CUDA device: <reason from the runtime>".
// Never throws, never aborts.
bool CudaDeviceAvailable(std::string* why);

// The CUDA rasterizer. Callers check CudaDeviceAvailable first (the factory
// in kernels/rasterizer.cc does).
std::unique_ptr<Rasterizer> CreateCudaRasterizer();

}  // namespace dypho::kernels::cuda
