#include "cumuli/parallel.hpp"

#include <memory>

#if defined(_WIN32)
#include <process.h>
#define CUMULI_GETPID _getpid
#else
#include <unistd.h>
#define CUMULI_GETPID getpid
#endif

namespace cumuli {

namespace {

// Spins until done() or `limit` has passed; true if done() came true.
template <class Done>
bool spin_until(const Done& done, std::chrono::microseconds limit) {
  const auto until = std::chrono::steady_clock::now() + limit;
  for (unsigned i = 0;; ++i) {
    if (done()) return true;
    // Read the clock every 64 rounds; a pause between reads yields the core's pipeline.
    if ((i & 63u) == 63u && std::chrono::steady_clock::now() >= until) return false;
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  }
}

// A pool and the process it belongs to: after fork() the child sees its parent's pool, whose
// threads it does not have.
struct OwnedPool {
  WorkerPool pool;
  long pid;
  explicit OwnedPool(long owner) : pid(owner) {}
};

std::atomic<OwnedPool*> the_pool{nullptr};

}  // namespace

WorkerPool& WorkerPool::instance() {
  const long pid = static_cast<long>(CUMULI_GETPID());
  OwnedPool* current = the_pool.load(std::memory_order_acquire);
  for (;;) {
    if (current != nullptr && current->pid == pid) return current->pool;
    // First use in this process. The pool is never freed (see parallel.hpp); one that
    // a fork left behind is abandoned as it is, since its mutex may be held by a thread that the
    // child does not have.
    auto fresh = std::make_unique<OwnedPool>(pid);
    if (the_pool.compare_exchange_strong(current, fresh.get(), std::memory_order_acq_rel))
      return fresh.release()->pool;
    // Another thread installed one first: `current` now holds it; check it again.
  }
}

unsigned WorkerPool::start(unsigned helpers, const std::function<void()>& job) {
  if (helpers == 0) return 0;
  bool expected = false;
  if (!busy_.compare_exchange_strong(expected, true, std::memory_order_acquire)) return 0;
  std::unique_lock<std::mutex> guard(lock_);
  const unsigned want = std::min(helpers, kMaxThreads);
  while (threads_ < want) {
    try {
      std::thread(&WorkerPool::work, this, threads_).detach();
    } catch (const std::system_error&) {
      break;  // the system refuses more threads: use those there are
    }
    ++threads_;
  }
  const unsigned n = std::min(want, threads_);
  if (n == 0) {
    busy_.store(false, std::memory_order_release);
    return 0;
  }
  job_ = &job;
  wanted_ = n;
  generation_.fetch_add(1, std::memory_order_release);
  guard.unlock();
  wake_.notify_all();
  return n;
}

void WorkerPool::finish() {
  // Close the job: a helper that wakes from now on does not join it. The caller has run out of
  // chunks, so one that has not joined yet has nothing left to do, and waiting for it to wake
  // (milliseconds for an idle vCPU) would only delay the caller.
  {
    std::lock_guard<std::mutex> guard(lock_);
    job_ = nullptr;
  }
  spin_until([this] { return running_.load(std::memory_order_acquire) == 0; }, kSpin);
  {
    std::unique_lock<std::mutex> guard(lock_);
    done_.wait(guard, [this] { return running_.load(std::memory_order_relaxed) == 0; });
  }
  busy_.store(false, std::memory_order_release);
}

void WorkerPool::work(unsigned index) {
  std::uint64_t seen = 0;
  for (;;) {
    spin_until([&] { return generation_.load(std::memory_order_acquire) != seen; }, kSpin);
    std::unique_lock<std::mutex> guard(lock_);
    wake_.wait(guard, [&] { return generation_.load(std::memory_order_relaxed) != seen; });
    seen = generation_.load(std::memory_order_relaxed);
    if (job_ == nullptr || index >= wanted_) continue;  // closed already, or not asked
    const std::function<void()>* job = job_;
    running_.fetch_add(1, std::memory_order_relaxed);  // joined: finish() waits for it
    guard.unlock();
    (*job)();  // parallel_chunks' worker: it catches what its chunks throw
    guard.lock();
    if (running_.fetch_sub(1, std::memory_order_acq_rel) == 1) done_.notify_one();
  }
}

}  // namespace cumuli
