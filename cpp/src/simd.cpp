#include "cumuli/simd.hpp"

#include <atomic>
#include <cstdlib>
#include <stdexcept>

namespace cumuli {

namespace {

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__)
#define CUMULI_X86_DISPATCH 1
#endif

// -1: not chosen yet (the first simd_level() reads CUMULI_SIMD).
std::atomic<int> g_level{-1};

SimdLevel default_level() {
  SimdLevel level = simd_best();
  if (const char* env = std::getenv("CUMULI_SIMD")) {
    const std::string name(env);
    if (name.empty() || name == "auto") return level;
    try {
      SimdLevel want = parse_simd_level(name);
      while (!simd_supported(want)) want = static_cast<SimdLevel>(static_cast<int>(want) - 1);
      level = want;
    } catch (const std::invalid_argument&) {
      // An unknown name is reported by the Python layer (cumuli.noise warns at import).
    }
  }
  return level;
}

// -1: not chosen yet (the first simd_fetch() reads CUMULI_SIMD_FETCH).
std::atomic<int> g_fetch{-1};

SimdFetch default_fetch() {
  if (const char* env = std::getenv("CUMULI_SIMD_FETCH")) {
    const std::string name(env);
    if (name == "gather") return SimdFetch::Gather;
    if (name == "loads") return SimdFetch::Loads;
    if (name == "cells") return SimdFetch::Cells;
    // Empty, "auto" or unknown (the Python layer warns): this CPU's preferred fetch.
  }
  return simd_fetch_preferred();
}

}  // namespace

const char* simd_fetch_name(SimdFetch fetch) {
  switch (fetch) {
    case SimdFetch::Loads:
      return "loads";
    case SimdFetch::Cells:
      return "cells";
    default:
      return "gather";
  }
}

SimdFetch parse_simd_fetch(const std::string& name) {
  if (name == "gather") return SimdFetch::Gather;
  if (name == "loads") return SimdFetch::Loads;
  if (name == "cells") return SimdFetch::Cells;
  throw std::invalid_argument("SIMD fetch must be 'gather', 'loads' or 'cells', got '" + name +
                              "'");
}

SimdFetch simd_fetch_preferred() {
#ifdef CUMULI_X86_DISPATCH
  // Measured (bench_noise): AMD's gathers are slow and its L3 is near, so whole cells win there
  // (Zen 5); Intel's gathers are fast and its L3 far, so the gathers from the 1.1 MB lattice,
  // which stays in L2, won on every point set tried (Xeon with AVX-512).
  if (__builtin_cpu_is("amd")) return SimdFetch::Cells;
#endif
  return SimdFetch::Gather;
}

SimdFetch simd_fetch() {
  int fetch = g_fetch.load(std::memory_order_relaxed);
  if (fetch < 0) {
    int expected = -1;
    g_fetch.compare_exchange_strong(expected, static_cast<int>(default_fetch()));
    fetch = g_fetch.load(std::memory_order_relaxed);
  }
  return static_cast<SimdFetch>(fetch);
}

void set_simd_fetch(SimdFetch fetch) {
  g_fetch.store(static_cast<int>(fetch), std::memory_order_relaxed);
}

void reset_simd_fetch() {
  g_fetch.store(static_cast<int>(default_fetch()), std::memory_order_relaxed);
}

const char* simd_name(SimdLevel level) {
  switch (level) {
    case SimdLevel::Avx2:
      return "avx2";
    case SimdLevel::Avx512:
      return "avx512";
    case SimdLevel::Scalar:
    default:
      return "scalar";
  }
}

SimdLevel parse_simd_level(const std::string& name) {
  if (name == "scalar") return SimdLevel::Scalar;
  if (name == "avx2") return SimdLevel::Avx2;
  if (name == "avx512") return SimdLevel::Avx512;
  throw std::invalid_argument("SIMD level must be 'scalar', 'avx2' or 'avx512', got '" + name +
                              "'");
}

bool simd_supported(SimdLevel level) {
  switch (level) {
    case SimdLevel::Scalar:
      return true;
#ifdef CUMULI_X86_DISPATCH
    // __builtin_cpu_supports also checks that the OS saves the wide registers (XGETBV).
    case SimdLevel::Avx2:
      return __builtin_cpu_supports("avx2");
    case SimdLevel::Avx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw");
#endif
    default:
      return false;
  }
}

SimdLevel simd_best() {
  if (simd_supported(SimdLevel::Avx512)) return SimdLevel::Avx512;
  if (simd_supported(SimdLevel::Avx2)) return SimdLevel::Avx2;
  return SimdLevel::Scalar;
}

SimdLevel simd_level() {
  int level = g_level.load(std::memory_order_relaxed);
  if (level < 0) {
    int expected = -1;
    const int chosen = static_cast<int>(default_level());
    g_level.compare_exchange_strong(expected, chosen);
    level = g_level.load(std::memory_order_relaxed);
  }
  return static_cast<SimdLevel>(level);
}

void set_simd_level(SimdLevel level) {
  if (!simd_supported(level))
    throw std::invalid_argument(std::string("SIMD level '") + simd_name(level) +
                                "' is not supported by this CPU or build");
  g_level.store(static_cast<int>(level), std::memory_order_relaxed);
}

void reset_simd_level() {
  g_level.store(static_cast<int>(default_level()), std::memory_order_relaxed);
}

}  // namespace cumuli
