#include "cumuli/noise.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "cumuli/parallel.hpp"
#include "cumuli/rng.hpp"

namespace cumuli {

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

Noise::Noise(std::uint64_t seed, int size) : seed_(seed), size_(size) {
  if (size < 2 || size > kMaxSize)
    throw std::invalid_argument("size must be in [2, " + std::to_string(kMaxSize) + "], got " +
                                std::to_string(size));
  const std::size_t n = static_cast<std::size_t>(size) * size * size;
  lattice_.resize(n);
  Rng rng(seed);
  for (auto& v : lattice_) v = rng.uniform();
}

namespace {
// Wrap an integer texel index into [0, size). For a power-of-two size (the paper's 64) a mask
// gives the same index without the integer division, which dominated the fBm's cost.
inline int wrap(int i, int size) {
  if ((size & (size - 1)) == 0) return i & (size - 1);
  const int r = i % size;
  return r < 0 ? r + size : r;
}

// floor(x) as an int for |x| < 2³¹ (lattice coordinates always are): the same value as
// std::floor without the libm call that a baseline x86-64 build makes for it.
inline int floor_int(float x) {
  const int i = static_cast<int>(x);
  return x < static_cast<float>(i) ? i - 1 : i;
}
}  // namespace

float Noise::lattice_at(glm::vec3 u) const {
  const glm::vec3 x = u - 0.5f;
  const int fx = floor_int(x.x), fy = floor_int(x.y), fz = floor_int(x.z);
  const glm::vec3 w = x - glm::vec3(static_cast<float>(fx), static_cast<float>(fy),
                                    static_cast<float>(fz));
  const int x0 = wrap(fx, size_), x1 = wrap(x0 + 1, size_);
  const int y0 = wrap(fy, size_), y1 = wrap(y0 + 1, size_);
  const int z0 = wrap(fz, size_), z1 = wrap(z0 + 1, size_);
  // Blend along x, then y, then z (the order a GL trilinear filter uses).
  const float c00 = texel(x0, y0, z0) + w.x * (texel(x1, y0, z0) - texel(x0, y0, z0));
  const float c10 = texel(x0, y1, z0) + w.x * (texel(x1, y1, z0) - texel(x0, y1, z0));
  const float c01 = texel(x0, y0, z1) + w.x * (texel(x1, y0, z1) - texel(x0, y0, z1));
  const float c11 = texel(x0, y1, z1) + w.x * (texel(x1, y1, z1) - texel(x0, y1, z1));
  const float c0 = c00 + w.y * (c10 - c00);
  const float c1 = c01 + w.y * (c11 - c01);
  return c0 + w.z * (c1 - c0);
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

#if defined(__GNUC__) || defined(__clang__)
namespace {
typedef float v4f __attribute__((vector_size(16)));
typedef int v4i __attribute__((vector_size(16)));
}  // namespace
#endif

void Noise::fbm_batch(const float* xs, const float* ys, const float* zs, std::size_t count,
                      float* out, const FbmParams& params) const {
  std::size_t i = 0;
#if defined(__GNUC__) || defined(__clang__)
  // Four points per iteration, lane for lane the arithmetic of lattice_at() and fbm(): each
  // vector operation is the IEEE operation the scalar code does, so the results are identical.
  const int size = size_;
  const bool pow2 = (size & (size - 1)) == 0;
  int log2 = 0;
  while ((1 << log2) < size) ++log2;
  const float* lat = lattice_.data();
  const auto wrap4 = [&](v4i a) {
    if (pow2) return a & (size - 1);
    v4i r = a % size;
    return r + ((r < 0) & size);
  };
  for (; i + 4 <= count; i += 4) {
    const v4f px = {xs[i], xs[i + 1], xs[i + 2], xs[i + 3]};
    const v4f py = {ys[i], ys[i + 1], ys[i + 2], ys[i + 3]};
    const v4f pz = {zs[i], zs[i + 1], zs[i + 2], zs[i + 3]};
    v4f sum = {0.0f, 0.0f, 0.0f, 0.0f};
    float amplitude = 1.0f;
    float scale = params.frequency;
    for (int o = 1; o <= params.octaves; ++o) {
      amplitude *= params.gain;
      scale *= params.lacunarity;
      const v4f ux = px * scale - 0.5f, uy = py * scale - 0.5f, uz = pz * scale - 0.5f;
      // floor: truncate, then step down where truncation rounded up (negative non-integers).
      v4i fx = __builtin_convertvector(ux, v4i), fy = __builtin_convertvector(uy, v4i),
          fz = __builtin_convertvector(uz, v4i);
      fx += (ux < __builtin_convertvector(fx, v4f));  // true lanes are −1
      fy += (uy < __builtin_convertvector(fy, v4f));
      fz += (uz < __builtin_convertvector(fz, v4f));
      const v4f wx = ux - __builtin_convertvector(fx, v4f);
      const v4f wy = uy - __builtin_convertvector(fy, v4f);
      const v4f wz = uz - __builtin_convertvector(fz, v4f);
      const v4i x0 = wrap4(fx), x1 = wrap4(x0 + 1);
      const v4i y0 = wrap4(fy), y1 = wrap4(y0 + 1);
      const v4i z0 = wrap4(fz), z1 = wrap4(z0 + 1);
      // Row offsets (z·size + y)·size; shifts for a power-of-two size (same numbers, and SSE2
      // has no 32-bit lane multiply).
      v4i r00, r10, r01, r11;
      if (pow2) {
        r00 = (z0 << (2 * log2)) | (y0 << log2), r10 = (z0 << (2 * log2)) | (y1 << log2);
        r01 = (z1 << (2 * log2)) | (y0 << log2), r11 = (z1 << (2 * log2)) | (y1 << log2);
      } else {
        r00 = (z0 * size + y0) * size, r10 = (z0 * size + y1) * size;
        r01 = (z1 * size + y0) * size, r11 = (z1 * size + y1) * size;
      }
      v4f t000, t100, t010, t110, t001, t101, t011, t111;
      for (int k = 0; k < 4; ++k) {
        t000[k] = lat[r00[k] + x0[k]], t100[k] = lat[r00[k] + x1[k]];
        t010[k] = lat[r10[k] + x0[k]], t110[k] = lat[r10[k] + x1[k]];
        t001[k] = lat[r01[k] + x0[k]], t101[k] = lat[r01[k] + x1[k]];
        t011[k] = lat[r11[k] + x0[k]], t111[k] = lat[r11[k] + x1[k]];
      }
      const v4f c00 = t000 + wx * (t100 - t000);
      const v4f c10 = t010 + wx * (t110 - t010);
      const v4f c01 = t001 + wx * (t101 - t001);
      const v4f c11 = t011 + wx * (t111 - t011);
      const v4f c0 = c00 + wy * (c10 - c00);
      const v4f c1 = c01 + wy * (c11 - c01);
      sum += amplitude * (c0 + wz * (c1 - c0));
    }
    for (int k = 0; k < 4; ++k) out[i + k] = sum[k];
  }
#endif
  for (; i < count; ++i) out[i] = fbm(glm::vec3(xs[i], ys[i], zs[i]), params);
}

void Noise::fbm_many(const float* points, std::size_t count, float* out, const FbmParams& params,
                     int threads) const {
  params.validate();
  parallel_chunks(count, threads, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const float* p = points + 3 * i;
      out[i] = fbm(glm::vec3(p[0], p[1], p[2]), params);
    }
  });
}

}  // namespace cumuli
