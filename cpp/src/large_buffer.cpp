#include "cumuli/large_buffer.hpp"

#include <cstdint>
#include <deque>
#include <mutex>
#include <new>
#include <utility>

#if defined(__linux__)
#include <sys/mman.h>
#define CUMULI_MAP_LARGE 1
#endif

namespace cumuli {
namespace {

constexpr std::size_t kPage = std::size_t{4} << 10;
constexpr std::align_val_t kAlign{64};

bool mapped(std::size_t bytes) { return bytes >= kLargeBytes && detail::large_mapping_available(); }

// The size a block of `bytes` really takes: whole 2 MiB units when mapped, whole pages else (so
// that requests a few bytes apart share idle blocks).
std::size_t rounded(std::size_t bytes) {
  const std::size_t unit = mapped(bytes) ? kLargeBytes : kPage;
  return (bytes + unit - 1) / unit * unit;
}

// A 2 MiB-aligned mapping of `bytes` (a multiple of 2 MiB), advised as huge pages; nullptr when
// it cannot be had.
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

// Makes a block of `size` (already rounded) afresh.
void* make_block(std::size_t size) {
  if (mapped(size)) {
    if (void* p = map_large(size)) return p;
    throw std::bad_alloc();
  }
  return ::operator new(size, kAlign);
}

// Gives a block of `size` (already rounded) back to the system.
void free_block(void* p, std::size_t size) noexcept {
#ifdef CUMULI_MAP_LARGE
  if (mapped(size)) {
    munmap(p, size);
    return;
  }
#endif
  ::operator delete(p, size, kAlign);
}

struct Block {
  void* p;
  std::size_t size;
};

// The idle blocks, oldest first. Reuse takes the most recently freed block of the size (the
// likeliest to be in cache); the limit gives back the oldest.
class BlockCache {
 public:
  void* take(std::size_t size) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      for (auto it = idle_.rbegin(); it != idle_.rend(); ++it) {
        if (it->size != size) continue;
        void* p = it->p;
        idle_bytes_ -= size;
        idle_.erase(std::next(it).base());
        ++hits_;
        return p;
      }
      ++misses_;
    }
    return make_block(size);
  }

  void put(void* p, std::size_t size) noexcept {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (size > limit_) {
      free_block(p, size);
      return;
    }
    try {
      idle_.push_back({p, size});
    } catch (...) {  // no room to remember it: give it back
      free_block(p, size);
      return;
    }
    idle_bytes_ += size;
    trim();
  }

  std::size_t set_limit(std::size_t bytes) {
    const std::lock_guard<std::mutex> lock(mutex_);
    const std::size_t previous = std::exchange(limit_, bytes);
    trim();
    return previous;
  }

  std::size_t release() {
    std::deque<Block> out;
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      out.swap(idle_);
      idle_bytes_ = 0;
    }
    std::size_t bytes = 0;
    for (const Block& b : out) {
      bytes += b.size;
      free_block(b.p, b.size);
    }
    return bytes;
  }

  BufferCacheStats stats() {
    const std::lock_guard<std::mutex> lock(mutex_);
    return {idle_.size(), idle_bytes_, limit_, hits_, misses_};
  }

 private:
  // Gives back the oldest idle blocks until the rest fit the limit.
  void trim() noexcept {
    while (idle_bytes_ > limit_) {
      free_block(idle_.front().p, idle_.front().size);
      idle_bytes_ -= idle_.front().size;
      idle_.pop_front();
    }
  }

  std::mutex mutex_;
  std::deque<Block> idle_;
  std::size_t idle_bytes_ = 0;
  std::size_t limit_ = kDefaultBufferCacheBytes;
  std::size_t hits_ = 0, misses_ = 0;
};

// The process's cache, never destroyed: arrays handed to Python may be freed after static
// destructors have run (at interpreter exit), and must still find it.
BlockCache& cache() {
  alignas(BlockCache) static unsigned char storage[sizeof(BlockCache)];
  static BlockCache* const instance = ::new (static_cast<void*>(storage)) BlockCache();
  return *instance;
}

}  // namespace

BufferCacheStats buffer_cache_stats() { return cache().stats(); }
std::size_t set_buffer_cache_limit(std::size_t bytes) { return cache().set_limit(bytes); }
std::size_t release_buffer_cache() { return cache().release(); }

namespace detail {

bool large_mapping_available() {
#ifdef CUMULI_MAP_LARGE
  return true;
#else
  return false;
#endif
}

void* acquire_block(std::size_t bytes) { return cache().take(rounded(bytes)); }

void release_block(void* p, std::size_t bytes) noexcept { cache().put(p, rounded(bytes)); }

}  // namespace detail
}  // namespace cumuli
