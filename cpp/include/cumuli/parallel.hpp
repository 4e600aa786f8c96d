// Deterministic parallel loops on std::thread.
//
// Work is split into contiguous chunks of the index range; each index is computed by exactly one
// thread with no shared accumulation, so the output is independent of the thread count (and of
// the chunking).
//
// Cancellation and progress: the thread that starts a loop calls an optional hook, between its
// chunks and at most every 50 ms, with the chunks started so far and their total; the hook says
// whether to stop (the Python bindings install one that runs Python's signal handlers, so Ctrl-C
// interrupts a long render, and that moves a progress bar). When it says stop, no further chunk
// is started, the running ones finish and the loop throws `Interrupted`. The core itself knows
// no Python.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

namespace cumuli {

// Thrown by a loop whose interrupt hook asked it to stop.
struct Interrupted : std::exception {
  const char* what() const noexcept override { return "interrupted"; }
};

// The hook: (chunks started, chunks in all) → true to stop. Called only on the thread that
// started the loop.
using InterruptHook = bool (*)(std::size_t, std::size_t);
inline std::atomic<InterruptHook>& interrupt_hook() {
  static std::atomic<InterruptHook> hook{nullptr};
  return hook;
}

namespace detail {
// True while this thread runs a chunk: a loop nested inside one does not ask the hook.
inline thread_local bool in_chunk = false;

struct ChunkScope {
  bool saved;
  ChunkScope() : saved(in_chunk) { in_chunk = true; }
  ~ChunkScope() { in_chunk = saved; }
  ChunkScope(const ChunkScope&) = delete;
  ChunkScope& operator=(const ChunkScope&) = delete;
};

// Asks the hook at most every 50 ms.
class InterruptPoll {
 public:
  InterruptPoll() : hook_(in_chunk ? nullptr : interrupt_hook().load()), last_(Clock::now()) {}
  bool stop(std::size_t done, std::size_t total) {
    if (hook_ == nullptr) return false;
    const auto now = Clock::now();
    if (now - last_ < std::chrono::milliseconds(50)) return false;
    last_ = now;
    return hook_(done, total);
  }

 private:
  using Clock = std::chrono::steady_clock;
  InterruptHook hook_;
  Clock::time_point last_;
};
}  // namespace detail

// Worker threads kept between loops (one pool per process). Starting a std::thread and joining it
// costs ≈ 30 µs here, and a new thread starts with empty thread_local buffers: for calls of
// ~0.1 ms (fBm on a few thousand points) that was a fifth of their time. A loop
// borrows the pool when nobody else holds it; otherwise (a loop nested in a chunk, or loops started
// at once from several Python threads) it starts its own threads as before. Which threads run a
// chunk never changes what the chunk computes, so results do not depend on it.
//
// Between jobs, and while the caller waits for the last chunks, a thread spins for kSpin before it
// sleeps on a condition variable. A sleeping thread's CPU may go idle, and on a virtual machine an
// idle vCPU can take milliseconds to be scheduled again (0.1 ms median, 2.4 ms at the 90th
// percentile measured on a 2-vCPU VM), against a few ms for a whole fBm call of 1 M points; the
// spin keeps a run of calls (a light pass, a sweep, a benchmark's repeats) on awake threads. A
// helper that wakes only after the caller has done every chunk does not hold the caller up:
// finish() closes the job and waits only for the helpers that joined it.
class WorkerPool {
 public:
  // The process's pool. A child made by fork() has none of its parent's threads: it gets a new
  // pool (the inherited one is abandoned, never touched).
  static WorkerPool& instance();

  // Offers job() to up to `helpers` pool threads and returns how many were asked, or 0 when the
  // pool is busy (the caller then starts threads itself). The caller must call finish() after
  // doing its own share of the work, and only then may the job's captures go out of scope. A
  // helper joins when it wakes, if finish() has not closed the job by then, so a job must be one
  // that the caller alone can complete (parallel_chunks' shared chunk counter is).
  unsigned start(unsigned helpers, const std::function<void()>& job);
  void finish();

  WorkerPool() = default;
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

 private:
  void work(unsigned index);

  // The threads are detached and parked between jobs: the pool lives as long as the process (it
  // is never destroyed, so exiting does not wait on a parked thread during static destruction).
  static constexpr unsigned kMaxThreads = 256;
  static constexpr std::chrono::microseconds kSpin{500};
  std::atomic<bool> busy_{false};
  std::mutex lock_;
  std::condition_variable wake_, done_;
  unsigned threads_ = 0;  // started so far
  unsigned wanted_ = 0;   // pool threads with index < wanted_ may join the current job
  // Written under lock_; also read without it by the spins (then checked again under lock_).
  std::atomic<unsigned> running_{0};  // of those, joined and not finished yet
  std::atomic<std::uint64_t> generation_{0};
  const std::function<void()>* job_ = nullptr;
};

// Threads to use for `requested` (0 = all cores), never more than there are items.
inline unsigned resolve_threads(int requested, std::size_t items) {
  unsigned n =
      requested > 0 ? static_cast<unsigned>(requested) : std::thread::hardware_concurrency();
  if (n == 0) n = 1;
  if (items < n) n = static_cast<unsigned>(std::max<std::size_t>(items, 1));
  return n;
}

// Calls fn(begin, end) on disjoint chunks covering [0, count).
template <class Fn>
void parallel_chunks(std::size_t count, int threads, Fn&& fn) {
  const unsigned n = resolve_threads(threads, count);
  detail::InterruptPoll poll;  // this (the calling) thread's
  // Several chunks per thread, handed out in order, keeps threads busy when items vary in cost
  // and lets the calling thread ask the interrupt hook often enough.
  const std::size_t chunks = std::min<std::size_t>(count, std::size_t{n} * 32);
  if (n <= 1) {
    if (chunks == 0) {
      fn(std::size_t{0}, count);
      return;
    }
    for (std::size_t c = 0; c < chunks; ++c) {
      if (poll.stop(c, chunks)) throw Interrupted{};
      detail::ChunkScope scope;
      fn(count * c / chunks, count * (c + 1) / chunks);
    }
    return;
  }
  std::size_t next = 0;
  std::mutex lock;
  std::exception_ptr error;
  auto worker = [&](bool caller) {
    detail::ChunkScope scope;
    for (;;) {
      std::size_t c;
      std::size_t started;
      {
        std::lock_guard<std::mutex> guard(lock);
        if (next >= chunks || error) return;
        c = next++;
        started = next;
      }
      try {
        fn(count * c / chunks, count * (c + 1) / chunks);
      } catch (...) {
        std::lock_guard<std::mutex> guard(lock);
        if (!error) error = std::current_exception();
      }
      if (caller) {
        detail::in_chunk = false;  // the poll runs outside any chunk
        const bool stop = poll.stop(started, chunks);
        detail::in_chunk = true;
        if (stop) {
          std::lock_guard<std::mutex> guard(lock);
          if (!error) error = std::make_exception_ptr(Interrupted{});
          return;
        }
      }
    }
  };
  const std::function<void()> helper = [&worker] { worker(false); };
  WorkerPool& shared = WorkerPool::instance();
  if (shared.start(n - 1, helper) > 0) {
    worker(true);
    shared.finish();
  } else {
    std::vector<std::thread> pool;
    pool.reserve(n - 1);
    for (unsigned i = 1; i < n; ++i) {
      // A thread the system refuses (process/memory limits) must not escape as an exception while
      // others run: their std::thread destructors would call std::terminate. The threads already
      // started share the chunks instead; the chunking, hence the result, is unchanged.
      try {
        pool.emplace_back(worker, false);
      } catch (const std::system_error&) {
        break;
      }
    }
    worker(true);
    for (auto& t : pool) t.join();
  }
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
