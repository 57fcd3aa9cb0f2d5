// Checked CUDA calls for the CUDA backend (nvcc only).
//
//   DYPHO_CUDA_CHECK(cudaMemcpy(...));        // any runtime call
//   Kernel<<<grid, block>>>(...);
//   DYPHO_CUDA_CHECK_LAUNCH("Kernel");        // launch errors (bad configuration, no image for this GPU)
//
// A failure throws dypho::InvalidInput whose message names the call (or the
// kernel), the CUDA error string, and the source file and line (added by
// DYPHO_CHECK_INPUT). Errors raised while a kernel runs surface at the next
// synchronising call, which is checked the same way.
#pragma once

#include <cuda_runtime.h>

#include "common/check.h"

#define DYPHO_CUDA_CHECK(call)                                                                 \
  do {                                                                                         \
    const cudaError_t dypho_cuda_error_ = (call);                                              \
    DYPHO_CHECK_INPUT(dypho_cuda_error_ == cudaSuccess)                                        \
        << "CUDA call " << #call << " failed: " << cudaGetErrorName(dypho_cuda_error_) << " (" \
        << cudaGetErrorString(dypho_cuda_error_) << ")";                                       \
  } while (0)

#define DYPHO_CUDA_CHECK_LAUNCH(kernel_name)                                                               \
  do {                                                                                                     \
    const cudaError_t dypho_cuda_error_ = cudaGetLastError();                                              \
    DYPHO_CHECK_INPUT(dypho_cuda_error_ == cudaSuccess)                                                    \
        << "CUDA kernel " << (kernel_name) << " failed to launch: " << cudaGetErrorName(dypho_cuda_error_) \
        << " (" << cudaGetErrorString(dypho_cuda_error_) << ")";                                           \
  } while (0)
