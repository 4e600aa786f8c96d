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
// Wrap an integer texel index into [0, size).
inline int wrap(int i, int size) {
  const int r = i % size;
  return r < 0 ? r + size : r;
}
}  // namespace

float Noise::lattice_at(glm::vec3 u) const {
  const glm::vec3 x = u - 0.5f;
  const glm::vec3 f = glm::vec3(std::floor(x.x), std::floor(x.y), std::floor(x.z));
  const glm::vec3 w = x - f;
  const int x0 = wrap(static_cast<int>(f.x), size_), x1 = wrap(x0 + 1, size_);
  const int y0 = wrap(static_cast<int>(f.y), size_), y1 = wrap(y0 + 1, size_);
  const int z0 = wrap(static_cast<int>(f.z), size_), z1 = wrap(z0 + 1, size_);
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
