// Storage for the light step's large arrays (a cloud's sun lattice, its sky visibility moments:
// megabytes each, made afresh for every cloud and every new sun).
//
// Fresh memory costs a page fault per 4 KiB page on first touch: for the default cumulus's
// ~11 MB of such arrays that was a quarter of its light step. Blocks of kLargeBytes or more are
// mapped on their own, aligned to 2 MiB, and advised as transparent huge pages (Linux,
// madvise(MADV_HUGEPAGE)): one fault per 2 MiB where the kernel allows it ("always" or
// "madvise" in /sys/kernel/mm/transparent_hugepage/enabled), the same faults as malloc's
// otherwise. Smaller blocks, and every block on other systems, come from std::allocator.
// The memory's contents and the results do not depend on which path a block took.
#pragma once

#include <cstddef>
#include <memory>
#include <new>
#include <vector>

namespace cumuli {

// Blocks at least this large take the mapped path.
constexpr std::size_t kLargeBytes = std::size_t{2} << 20;

namespace detail {
// A zero-filled mapping of at least `bytes` (a multiple of 2 MiB), 2 MiB-aligned where mapping is
// available; nullptr where it is not (the caller falls back to std::allocator).
void* map_large(std::size_t bytes);
void unmap_large(void* p, std::size_t bytes);
// Whether map_large can map on this system.
bool large_mapping_available();
inline std::size_t large_size(std::size_t bytes) {
  return (bytes + kLargeBytes - 1) / kLargeBytes * kLargeBytes;
}
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
    if (bytes >= kLargeBytes && detail::large_mapping_available()) {
      if (void* p = detail::map_large(detail::large_size(bytes))) return static_cast<T*>(p);
      throw std::bad_alloc();
    }
    return std::allocator<T>().allocate(n);
  }
  void deallocate(T* p, std::size_t n) noexcept {
    const std::size_t bytes = n * sizeof(T);
    if (bytes >= kLargeBytes && detail::large_mapping_available())
      detail::unmap_large(p, detail::large_size(bytes));
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
