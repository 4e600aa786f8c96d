// Storage for the light step's arrays (a cloud's sun lattice, its sky visibility moments, the
// diffusion's sources, solves and results: hundreds of kilobytes to megabytes each, made afresh
// for every cloud and every light step).
//
// Fresh memory costs a page fault per 4 KiB page on first touch, and the C library gives large
// freed blocks back to the system, so each light step paid those faults again: ~1,500 per
// default cumulus, a tenth of its time. Two remedies, both invisible in the results (every
// vector initialises its values):
// - Blocks of kPooledBytes or more are recycled through one process-wide cache of idle blocks
//   (at most buffer_cache_limit() bytes, the least recently freed given back first): the next
//   block of the same rounded size reuses one, already faulted in.
// - Blocks of kLargeBytes or more are mapped on their own, aligned to 2 MiB, and advised as
//   transparent huge pages (Linux, madvise(MADV_HUGEPAGE)): one fault per 2 MiB where the kernel
//   allows it ("always" or "madvise" in /sys/kernel/mm/transparent_hugepage/enabled).
// Smaller blocks come from std::allocator.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <vector>

namespace cumuli {

// Blocks at least this large are recycled through the idle-block cache.
constexpr std::size_t kPooledBytes = std::size_t{64} << 10;
// Blocks at least this large take the mapped path.
constexpr std::size_t kLargeBytes = std::size_t{2} << 20;
// The idle-block cache's default limit, in bytes.
constexpr std::size_t kDefaultBufferCacheBytes = std::size_t{256} << 20;

// What the idle-block cache holds and has done since the process started.
struct BufferCacheStats {
  std::size_t idle_blocks = 0;
  std::size_t idle_bytes = 0;
  std::size_t limit_bytes = 0;
  std::size_t hits = 0;    // blocks handed out from the cache
  std::size_t misses = 0;  // blocks of kPooledBytes or more made afresh
};

BufferCacheStats buffer_cache_stats();
// Sets the most bytes the cache keeps idle (0: none), giving back what is over it; returns the
// previous limit.
std::size_t set_buffer_cache_limit(std::size_t bytes);
// Gives every idle block back to the system; returns the bytes given back.
std::size_t release_buffer_cache();

namespace detail {
// A block of at least `bytes` (kPooledBytes or more), from the cache or made afresh: mapped and
// 2 MiB-aligned from kLargeBytes on where mapping is available, else 64-byte aligned. Its
// contents are unspecified. Throws std::bad_alloc when no memory can be had.
void* acquire_block(std::size_t bytes);
// Returns a block from acquire_block(bytes) to the cache (or to the system).
void release_block(void* p, std::size_t bytes) noexcept;
// Whether blocks of kLargeBytes or more are mapped on this system.
bool large_mapping_available();
}  // namespace detail

template <class T>
struct LargeAllocator {
  using value_type = T;
  LargeAllocator() = default;
  template <class U>
  LargeAllocator(const LargeAllocator<U>&) noexcept {}

  T* allocate(std::size_t n) {
    if (n > static_cast<std::size_t>(-1) / sizeof(T)) throw std::bad_alloc();
    const std::size_t bytes = n * sizeof(T);
    if (bytes >= kPooledBytes) return static_cast<T*>(detail::acquire_block(bytes));
    return std::allocator<T>().allocate(n);
  }
  void deallocate(T* p, std::size_t n) noexcept {
    const std::size_t bytes = n * sizeof(T);
    if (bytes >= kPooledBytes)
      detail::release_block(p, bytes);
    else
      std::allocator<T>().deallocate(p, n);
  }
  template <class U>
  bool operator==(const LargeAllocator<U>&) const noexcept {
    return true;
  }
  template <class U>
  bool operator!=(const LargeAllocator<U>&) const noexcept {
    return false;
  }
};

template <class T>
using LargeVector = std::vector<T, LargeAllocator<T>>;

}  // namespace cumuli
