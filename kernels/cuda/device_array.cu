// Device memory helpers declared in device_array.h.
//
// Allocations are stream-ordered (cudaMallocAsync / cudaFreeAsync on the
// default stream) when the device supports memory pools, so freeing a
// temporary does not stall the host until the device is idle, as cudaFree
// does; otherwise plain cudaMalloc / cudaFree. The choice is made once per
// process, on the first allocation, for the then-current device. The device's
// default pool is then told to keep freed memory for reuse (its release
// threshold raised) instead of returning it to the driver at every
// synchronisation, which Forward does once per call: like the CPU backend's
// KeepFreedMemory, repeated renders then reuse memory instead of mapping it
// again each time.
#include <cuda_runtime.h>

#include <cstdint>

#include "kernels/cuda/cuda_check.cuh"
#include "kernels/cuda/device_array.h"

namespace dypho::kernels::cuda {
namespace {

bool UseStreamOrderedAllocator() {
  static const bool use = [] {
    int device = 0;
    int supported = 0;
    if (cudaGetDevice(&device) != cudaSuccess ||
        cudaDeviceGetAttribute(&supported, cudaDevAttrMemoryPoolsSupported, device) != cudaSuccess) {
      cudaGetLastError();  // not sticky: clear it so it is not reported by a later check
      return false;
    }
    if (supported == 0) return false;
    cudaMemPool_t pool;
    if (cudaDeviceGetDefaultMemPool(&pool, device) == cudaSuccess) {
      uint64_t keep = UINT64_MAX;
      if (cudaMemPoolSetAttribute(pool, cudaMemPoolAttrReleaseThreshold, &keep) != cudaSuccess) cudaGetLastError();
    } else {
      cudaGetLastError();
    }
    return true;
  }();
  return use;
}

}  // namespace

void* DeviceAlloc(size_t bytes) {
  if (bytes == 0) return nullptr;
  void* ptr = nullptr;
  const cudaError_t error =
      UseStreamOrderedAllocator() ? cudaMallocAsync(&ptr, bytes, 0) : cudaMalloc(&ptr, bytes);
  if (error != cudaSuccess) cudaGetLastError();  // an allocation failure is not sticky
  DYPHO_CHECK_INPUT(error == cudaSuccess)
      << "CUDA: cannot allocate " << bytes << " bytes of device memory: " << cudaGetErrorName(error) << " ("
      << cudaGetErrorString(error) << ")";
  return ptr;
}

void DeviceFree(void* ptr) noexcept {
  if (ptr == nullptr) return;
  const cudaError_t error = UseStreamOrderedAllocator() ? cudaFreeAsync(ptr, 0) : cudaFree(ptr);
  if (error != cudaSuccess) cudaGetLastError();
}

long long DevicePoolPeakBytes(bool reset) {
  if (!UseStreamOrderedAllocator()) return -1;
  int device = 0;
  DYPHO_CUDA_CHECK(cudaGetDevice(&device));
  cudaMemPool_t pool;
  DYPHO_CUDA_CHECK(cudaDeviceGetDefaultMemPool(&pool, device));
  unsigned long long high = 0;  // cuuint64_t
  DYPHO_CUDA_CHECK(cudaMemPoolGetAttribute(pool, cudaMemPoolAttrUsedMemHigh, &high));
  if (reset) {
    unsigned long long zero = 0;  // the only value this attribute may be set to
    DYPHO_CUDA_CHECK(cudaMemPoolSetAttribute(pool, cudaMemPoolAttrUsedMemHigh, &zero));
  }
  return static_cast<long long>(high);
}

void CopyToDevice(void* device_dst, const void* host_src, size_t bytes) {
  if (bytes == 0) return;
  DYPHO_CUDA_CHECK(cudaMemcpy(device_dst, host_src, bytes, cudaMemcpyHostToDevice));
}

void CopyToHost(void* host_dst, const void* device_src, size_t bytes) {
  if (bytes == 0) return;
  DYPHO_CUDA_CHECK(cudaMemcpy(host_dst, device_src, bytes, cudaMemcpyDeviceToHost));
}

void DeviceZero(void* device_dst, size_t bytes) {
  if (bytes == 0) return;
  DYPHO_CUDA_CHECK(cudaMemsetAsync(device_dst, 0, bytes, 0));
}

void DeviceSynchronize() { DYPHO_CUDA_CHECK(cudaDeviceSynchronize()); }

}  // namespace dypho::kernels::cuda
