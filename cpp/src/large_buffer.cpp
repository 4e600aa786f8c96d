#include "cumuli/large_buffer.hpp"

#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#define CUMULI_MAP_LARGE 1
#endif

namespace cumuli::detail {

bool large_mapping_available() {
#ifdef CUMULI_MAP_LARGE
  return true;
#else
  return false;
#endif
}

void* map_large(std::size_t bytes) {
#ifdef CUMULI_MAP_LARGE
  // Over-map by one alignment, then unmap the head and tail around the aligned block.
  const std::size_t span = bytes + kLargeBytes;
  void* raw = mmap(nullptr, span, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) return nullptr;
  const auto start = reinterpret_cast<std::uintptr_t>(raw);
  const std::uintptr_t aligned = (start + kLargeBytes - 1) / kLargeBytes * kLargeBytes;
  const std::size_t head = aligned - start, tail = span - head - bytes;
  if (head > 0) munmap(raw, head);
  if (tail > 0) munmap(reinterpret_cast<void*>(aligned + bytes), tail);
  void* block = reinterpret_cast<void*>(aligned);
  madvise(block, bytes, MADV_HUGEPAGE);  // advice only: ignored where huge pages are off
  return block;
#else
  (void)bytes;
  return nullptr;
#endif
}

void unmap_large(void* p, std::size_t bytes) {
#ifdef CUMULI_MAP_LARGE
  munmap(p, bytes);
#else
  (void)p;
  (void)bytes;
#endif
}

}  // namespace cumuli::detail
