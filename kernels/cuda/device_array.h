// Device memory from plain C++: allocation, copies and an owning array, for
// code that is not compiled by nvcc (tests, the engine) and for the backend's
// own buffers. Defined in device_array.cu; every CUDA call is checked and a
// failure throws dypho::InvalidInput with the call, the CUDA error string and
// the source location. Copies run on the default stream and return when done.
// Memory comes from the device's default stream-ordered pool where supported
// (see device_array.cu), which this library sets to keep freed memory for
// reuse.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

namespace dypho::kernels::cuda {

// cudaMalloc; nullptr for 0 bytes. Throws on failure (e.g. out of memory,
// naming the size).
void* DeviceAlloc(size_t bytes);
// cudaFree; null is fine. Never throws (errors are ignored: it runs in
// destructors, possibly after an earlier CUDA error).
void DeviceFree(void* ptr) noexcept;
// Blocking copies between host and device memory; 0 bytes is a no-op.
void CopyToDevice(void* device_dst, const void* host_src, size_t bytes);
void CopyToHost(void* host_dst, const void* device_src, size_t bytes);
// cudaMemset to zero bytes (asynchronous on the default stream).
void DeviceZero(void* device_dst, size_t bytes);
// Waits for all work on the device; throws if any of it failed.
void DeviceSynchronize();

// High-water mark of the bytes in use in the current device's default memory
// pool (the stream-ordered allocator above) since the last reset, then reset
// it when `reset`; -1 when that allocator is not in use (peak unknown).
long long DevicePoolPeakBytes(bool reset);

// An owning array of `size()` values of a trivially copyable T in device
// memory. Move-only; frees in the destructor. Contents are undefined after
// Resize unless zeroed.
template <typename T>
class DeviceArray {
 public:
  DeviceArray() = default;
  explicit DeviceArray(size_t count) { Resize(count); }
  DeviceArray(const T* host, size_t count) : DeviceArray(count) { CopyFromHost(host, count); }
  explicit DeviceArray(const std::vector<T>& host) : DeviceArray(host.data(), host.size()) {}
  ~DeviceArray() { DeviceFree(data_); }

  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  DeviceArray(DeviceArray&& other) noexcept { swap(other); }
  DeviceArray& operator=(DeviceArray&& other) noexcept {
    if (this != &other) {
      DeviceArray dead(std::move(*this));  // frees the old memory on return
      swap(other);
    }
    return *this;
  }

  // Reallocates when the size differs; the old contents are discarded.
  void Resize(size_t count) {
    if (count == size_) return;
    DeviceFree(data_);
    data_ = nullptr;
    size_ = 0;
    data_ = static_cast<T*>(DeviceAlloc(count * sizeof(T)));
    size_ = count;
  }
  void Zero() { DeviceZero(data_, size_ * sizeof(T)); }
  void CopyFromHost(const T* host, size_t count) {
    Resize(count);
    CopyToDevice(data_, host, count * sizeof(T));
  }
  std::vector<T> ToHost() const {
    std::vector<T> host(size_);
    CopyToHost(host.data(), data_, size_ * sizeof(T));
    return host;
  }
  void swap(DeviceArray& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
  }

  T* data() { return data_; }
  const T* data() const { return data_; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

 private:
  T* data_ = nullptr;
  size_t size_ = 0;
};

}  // namespace dypho::kernels::cuda
