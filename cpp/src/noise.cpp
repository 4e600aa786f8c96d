#include "cumuli/noise.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "cumuli/parallel.hpp"
#include "cumuli/rng.hpp"

// Speed notes. The straightforward lookup (std::floor, then `%` to wrap each of the six indices)
// spends most of its time in integer divisions. Here:
//   * the lattice is also kept padded to (size+1)³, so a cell's upper corner never wraps;
//   * a power-of-two size wraps the lower corner with an `and`;
//   * floor() is a truncation plus a correction, exact while |x| < 2²² (larger coordinates, and
//     non-finite ones, take the general path with std::floor and fmod);
//   * fbm_many works on blocks of points octave by octave, so the index and weight arithmetic is a
//     plain loop over arrays that the compiler vectorises; the 8 texel loads of a block go into
//     arrays first, so that the blend is a vector loop too;
//   * fbm_block is also compiled for AVX2 (GCC function multi-versioning through glibc's ifunc,
//     chosen at load time by the CPU), where the loads become hardware gathers and the loops run
//     8 wide. The clone does not enable FMA and vector lanes round like scalars, so it gives the
//     same bits (measured: fBm of the light pass's points about −30 %).
// Every path performs the same float operations in the same order as eq. (1) written naively, so
// results are bit-identical between fbm(), fbm_many() and any thread count (the build uses
// -ffp-contract=off so no multiply-add is fused behind our back).

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__GLIBC__)
#define CUMULI_SIMD_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define CUMULI_SIMD_CLONES
#endif

namespace cumuli {

namespace {

constexpr std::size_t kBlock = 64;

// Below this magnitude int32 truncation is exact and cannot overflow.
constexpr float kFastLimit = 4194304.0f;  // 2^22

// floor(x) for |x| < 2^22: truncate, then step down where truncation rounded up (negative
// non-integers). Branch-free integer arithmetic so that loops using it vectorise (SSE2 has no
// floor instruction; std::floor would be a library call per coordinate).
inline float floor_small(float x) {
  const int t = static_cast<int>(x);
  return static_cast<float>(t - static_cast<int>(static_cast<float>(t) > x));
}

inline int wrap_mod(long long i, int size) {
  const long long r = i % size;
  return static_cast<int>(r < 0 ? r + size : r);
}

}  // namespace

void FbmParams::validate() const {
  if (octaves < 1 || octaves > 16)
    throw std::invalid_argument("octaves must be in [1, 16], got " + std::to_string(octaves));
  if (!std::isfinite(gain) || gain <= 0.0f)
    throw std::invalid_argument("gain must be a finite positive number");
  if (!std::isfinite(lacunarity) || lacunarity <= 0.0f)
    throw std::invalid_argument("lacunarity must be a finite positive number");
  if (!std::isfinite(frequency) || frequency <= 0.0f)
    throw std::invalid_argument("frequency must be a finite positive number");
}

Noise::Noise(std::uint64_t seed, int size) : seed_(seed), size_(size), mask_(-1) {
  if (size < 2 || size > kMaxSize)
    throw std::invalid_argument("size must be in [2, " + std::to_string(kMaxSize) + "], got " +
                                std::to_string(size));
  if ((size & (size - 1)) == 0) mask_ = size - 1;
  const std::size_t s = static_cast<std::size_t>(size);
  lattice_.resize(s * s * s);
  Rng rng(seed);
  for (auto& v : lattice_) v = rng.uniform();

  const std::size_t p = s + 1;
  padded_.resize(p * p * p);
  for (std::size_t z = 0; z < p; ++z)
    for (std::size_t y = 0; y < p; ++y)
      for (std::size_t x = 0; x < p; ++x)
        padded_[(z * p + y) * p + x] = lattice_[((z % s) * s + (y % s)) * s + (x % s)];
}

void Noise::split(float x, int& index, float& weight) const {
  if (std::fabs(x) < kFastLimit) {
    const float f = floor_small(x);
    weight = x - f;
    const int i = static_cast<int>(f);
    index = mask_ >= 0 ? (i & mask_) : wrap_mod(i, size_);
    return;
  }
  if (!std::isfinite(x)) {  // NaN in, NaN out (through the weight), without undefined casts
    index = 0;
    weight = x - x;
    return;
  }
  // |x| >= 2^22: x is an integer-valued float far beyond int range; reduce it in double, which
  // is exact (fmod is exact and every such float is an integer).
  const double f = std::floor(static_cast<double>(x));
  weight = x - static_cast<float>(f);
  double r = std::fmod(f, static_cast<double>(size_));
  if (r < 0.0) r += size_;
  index = static_cast<int>(r);
}

float Noise::blend(int ix, int iy, int iz, float wx, float wy, float wz) const {
  const std::size_t p = static_cast<std::size_t>(size_) + 1;
  const std::size_t pp = p * p;
  const float* c = padded_.data() + (static_cast<std::size_t>(iz) * p + iy) * p + ix;
  // Blend along x, then y, then z (the order a GL trilinear filter uses).
  const float c00 = c[0] + wx * (c[1] - c[0]);
  const float c10 = c[p] + wx * (c[p + 1] - c[p]);
  const float c01 = c[pp] + wx * (c[pp + 1] - c[pp]);
  const float c11 = c[pp + p] + wx * (c[pp + p + 1] - c[pp + p]);
  const float c0 = c00 + wy * (c10 - c00);
  const float c1 = c01 + wy * (c11 - c01);
  return c0 + wz * (c1 - c0);
}

float Noise::lattice_at(glm::vec3 u) const {
  const glm::vec3 x = u - 0.5f;
  int ix, iy, iz;
  float wx, wy, wz;
  split(x.x, ix, wx);
  split(x.y, iy, wy);
  split(x.z, iz, wz);
  return blend(ix, iy, iz, wx, wy, wz);
}

float Noise::fbm(glm::vec3 p, const FbmParams& params) const {
  float sum = 0.0f;
  float amplitude = 1.0f;
  float scale = params.frequency;
  for (int i = 1; i <= params.octaves; ++i) {
    amplitude *= params.gain;
    scale *= params.lacunarity;
    sum += amplitude * lattice_at(p * scale);
  }
  return sum;
}

CUMULI_SIMD_CLONES
void Noise::fbm_block(const float* points, std::size_t count, float* out,
                      const FbmParams& params) const {
  // Octave amplitudes and scales, accumulated exactly as fbm() does.
  const int octaves = std::min(params.octaves, 16);
  std::array<float, 16> amplitude{}, scale{};
  float a = 1.0f, s = params.frequency, max_scale = 0.0f;
  for (int o = 0; o < octaves; ++o) {
    a *= params.gain;
    s *= params.lacunarity;
    amplitude[o] = a;
    scale[o] = s;
    max_scale = std::max(max_scale, s);
  }

  alignas(32) float px[kBlock], py[kBlock], pz[kBlock], sum[kBlock];
  alignas(32) float wx[kBlock], wy[kBlock], wz[kBlock];
  alignas(32) int base[kBlock];
  alignas(32) float k000[kBlock], k100[kBlock], k010[kBlock], k110[kBlock];
  alignas(32) float k001[kBlock], k101[kBlock], k011[kBlock], k111[kBlock];
  // Rounded multiplication is monotonic, so |p|·max_scale bounds |p|·scale of every octave; the
  // test is written so that NaN fails it.
  int slow = mask_ < 0;
  for (std::size_t j = 0; j < 3 * count; ++j)
    slow |= static_cast<int>(!(std::fabs(points[j]) * max_scale < kFastLimit));
  for (std::size_t i = 0; i < count; ++i) {
    px[i] = points[3 * i];
    py[i] = points[3 * i + 1];
    pz[i] = points[3 * i + 2];
    sum[i] = 0.0f;
  }

  if (slow) {
    for (std::size_t i = 0; i < count; ++i)
      out[i] = fbm(glm::vec3(px[i], py[i], pz[i]), params);
    return;
  }

  const int p = size_ + 1;
  const int mask = mask_;
  for (int o = 0; o < octaves; ++o) {
    const float sc = scale[o];
    // Vectorisable: lower-corner index and weights of every point.
    for (std::size_t i = 0; i < count; ++i) {
      const float x = px[i] * sc - 0.5f;
      const float y = py[i] * sc - 0.5f;
      const float z = pz[i] * sc - 0.5f;
      const float fx = floor_small(x), fy = floor_small(y), fz = floor_small(z);
      wx[i] = x - fx;
      wy[i] = y - fy;
      wz[i] = z - fz;
      const int ix = static_cast<int>(fx) & mask;
      const int iy = static_cast<int>(fy) & mask;
      const int iz = static_cast<int>(fz) & mask;
      base[i] = (iz * p + iy) * p + ix;
    }
    // Scalar loads of the 8 corners into arrays (a gather SSE2 lacks), then the blend as a
    // vector loop over the block: the same operations per point, so the same bits.
    const std::size_t pu = static_cast<std::size_t>(p), pp = pu * pu;
    for (std::size_t i = 0; i < count; ++i) {
      const float* c = padded_.data() + base[i];
      k000[i] = c[0], k100[i] = c[1], k010[i] = c[pu], k110[i] = c[pu + 1];
      k001[i] = c[pp], k101[i] = c[pp + 1], k011[i] = c[pp + pu], k111[i] = c[pp + pu + 1];
    }
    const float amp = amplitude[o];
    for (std::size_t i = 0; i < count; ++i) {
      const float c00 = k000[i] + wx[i] * (k100[i] - k000[i]);
      const float c10 = k010[i] + wx[i] * (k110[i] - k010[i]);
      const float c01 = k001[i] + wx[i] * (k101[i] - k001[i]);
      const float c11 = k011[i] + wx[i] * (k111[i] - k011[i]);
      const float c0 = c00 + wy[i] * (c10 - c00);
      const float c1 = c01 + wy[i] * (c11 - c01);
      sum[i] += amp * (c0 + wz[i] * (c1 - c0));
    }
  }
  std::copy(sum, sum + count, out);
}

void Noise::fbm_many(const float* points, std::size_t count, float* out, const FbmParams& params,
                     int threads) const {
  params.validate();
  parallel_chunks(count, threads, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; i += kBlock) {
      const std::size_t n = std::min(kBlock, e - i);
      fbm_block(points + 3 * i, n, out + i, params);
    }
  });
}

}  // namespace cumuli
