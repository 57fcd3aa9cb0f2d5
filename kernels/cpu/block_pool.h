// Memory for the CPU rasterizer's large per-call arrays, kept between calls.
//
// A render allocates tens of megabytes (per-Gaussian records, spans, per-pixel
// state, backward accumulators). On virtual machines the first touch of a
// fresh page costs tens of microseconds (about 27 us here), so memory handed
// back to the operating system and faulted in again on every call costs more
// than the rendering itself; glibc's heap does not reliably prevent that when
// the sizes and the order of allocations change between calls. BlockPool keeps
// freed blocks (up to a cap) and hands the smallest fitting one to the next
// request. PoolVector<T> is a std::vector drawing from it that leaves trivial
// elements uninitialised on resize (every user writes before reading).
#pragma once

#include <cstddef>
#include <map>
#include <mutex>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace dypho::kernels::cpu {

class BlockPool {
 public:
  static constexpr size_t kAlign = 64;
  static constexpr size_t kMinPooledBytes = size_t{64} << 10;  // smaller requests go to operator new
  static constexpr size_t kMaxKeptBytes = size_t{2} << 30;     // free blocks kept at most

  static BlockPool& Instance() {
    static BlockPool* pool = new BlockPool;  // never destroyed: states may outlive static destruction
    return *pool;
  }

  void* Take(size_t bytes) {
    if (bytes < kMinPooledBytes) return ::operator new(bytes, std::align_val_t(kAlign));
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = free_.lower_bound(bytes);
      if (it != free_.end()) {
        void* p = it->second;
        kept_bytes_ -= it->first;
        free_.erase(it);
        return p;
      }
    }
    // Round up so slightly growing requests still reuse the block.
    const size_t capacity = bytes + bytes / 8 + kAlign;
    char* block = static_cast<char*>(::operator new(capacity + kAlign, std::align_val_t(kAlign)));
    *reinterpret_cast<size_t*>(block) = capacity;
    return block + kAlign;
  }

  void Give(void* p, size_t bytes) {
    if (p == nullptr) return;
    if (bytes < kMinPooledBytes) {
      ::operator delete(p, std::align_val_t(kAlign));
      return;
    }
    char* block = static_cast<char*>(p) - kAlign;
    const size_t capacity = *reinterpret_cast<size_t*>(block);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (kept_bytes_ + capacity <= kMaxKeptBytes) {
        free_.emplace(capacity, p);
        kept_bytes_ += capacity;
        return;
      }
    }
    ::operator delete(block, std::align_val_t(kAlign));
  }

 private:
  BlockPool() = default;
  std::mutex mutex_;
  std::multimap<size_t, void*> free_;  // usable capacity (stored in front of the block) -> block
  size_t kept_bytes_ = 0;
};

// Requests below kMinPooledBytes go straight to operator new and delete;
// allocate and deallocate see the same size, so they agree on which.
template <typename T>
struct PoolAllocator {
  using value_type = T;
  PoolAllocator() = default;
  template <typename U>
  PoolAllocator(const PoolAllocator<U>&) {}  // NOLINT: converting, as allocators require
  T* allocate(size_t n) {
    return static_cast<T*>(BlockPool::Instance().Take(n * sizeof(T)));
  }
  void deallocate(T* p, size_t n) { BlockPool::Instance().Give(p, n * sizeof(T)); }
  // Default-initialise (no zeroing) on resize; explicit values still work.
  template <typename U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
  template <typename U>
  bool operator==(const PoolAllocator<U>&) const { return true; }
  template <typename U>
  bool operator!=(const PoolAllocator<U>&) const { return false; }
};

template <typename T>
using PoolVector = std::vector<T, PoolAllocator<T>>;

}  // namespace dypho::kernels::cpu
