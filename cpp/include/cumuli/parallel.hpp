// Deterministic parallel loops on std::thread.
//
// Work is split into contiguous chunks of the index range; each index is computed by exactly one
// thread with no shared accumulation, so the output is independent of the thread count.
#pragma once

#include <algorithm>
#include <cstddef>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

namespace cumuli {

// Threads to use for `requested` (0 = all cores), never more than there are items.
inline unsigned resolve_threads(int requested, std::size_t items) {
  unsigned n = requested > 0 ? static_cast<unsigned>(requested) : std::thread::hardware_concurrency();
  if (n == 0) n = 1;
  if (items < n) n = static_cast<unsigned>(std::max<std::size_t>(items, 1));
  return n;
}

// Calls fn(begin, end) on disjoint chunks covering [0, count).
template <class Fn>
void parallel_chunks(std::size_t count, int threads, Fn&& fn) {
  const unsigned n = resolve_threads(threads, count);
  if (n <= 1) {
    fn(std::size_t{0}, count);
    return;
  }
  // Several chunks per thread, handed out in order, keeps threads busy when items vary in cost.
  const std::size_t chunks = std::min<std::size_t>(count, std::size_t{n} * 8);
  std::size_t next = 0;
  std::mutex lock;
  std::exception_ptr error;
  auto worker = [&] {
    for (;;) {
      std::size_t c;
      {
        std::lock_guard<std::mutex> guard(lock);
        if (next >= chunks || error) return;
        c = next++;
      }
      try {
        fn(count * c / chunks, count * (c + 1) / chunks);
      } catch (...) {
        std::lock_guard<std::mutex> guard(lock);
        if (!error) error = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(n - 1);
  for (unsigned i = 1; i < n; ++i) {
    // A thread the system refuses (process/memory limits) must not escape as an exception while
    // others run: their std::thread destructors would call std::terminate. The threads already
    // started share the chunks instead; the chunking, hence the result, is unchanged.
    try {
      pool.emplace_back(worker);
    } catch (const std::system_error&) {
      break;
    }
  }
  worker();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

// Calls fn(i) for each i in [0, count).
template <class Fn>
void parallel_for(std::size_t count, int threads, Fn&& fn) {
  parallel_chunks(count, threads, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) fn(i);
  });
}

}  // namespace cumuli
