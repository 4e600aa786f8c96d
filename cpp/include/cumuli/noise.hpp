// Value-noise lattice and fBm (Jiménez de Parga & Gómez Palomo 2018, §3.1, eq. 1).
//
// The lattice is a size³ cube of uniform values in [0, 1). Lookups follow the GL texel-centre
// convention of a LINEAR / REPEAT 3D texture, so that the GLSL in shaders/common/noise.glsl returns
// the same numbers: at lattice coordinate u (in texels) we blend texels floor(u - 0.5) and the next
// with weight fract(u - 0.5), indices wrapped modulo size. World point p maps to u = p · f.
//
// Two noise versions fill the lattice. Version 1 (the table) draws its values from the seed's
// SplitMix64 stream, in [z][y][x] order; the wide kernels read them from memory. Version 2 (the
// hash) gives texel i = (z·size + y)·size + x the value hash_biased(hash_key(seed), i) − 1: the
// same uniform 2⁻²³-spaced values in [0, 1), independent per texel, periodic on the size³ cube, but
// the wide kernels compute them in registers instead of reading 1 MB of table (the GLSL twin hashes
// too). Both versions keep the table, so every other path reads it and returns the same bits.
#pragma once

#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

#include <glm/vec3.hpp>

namespace cumuli {

struct FbmParams {
  int octaves = 5;          // n
  float gain = 0.5f;        // w: amplitude of octave i is w^i
  float lacunarity = 2.0f;  // s: frequency of octave i is s^i · f
  float frequency = 1.0f;   // f: lattice texels per world unit

  void validate() const;  // throws std::invalid_argument naming the bad parameter
};

class Noise {
 public:
  static constexpr int kVersionTable = 1;  // values drawn from the seed's random stream
  static constexpr int kVersionHash = 2;   // values hashed from (seed, texel index)
  static constexpr int kDefaultVersion = kVersionHash;  // the table is the paper's: ask for it
  static constexpr int kMaxSize = 512;      // 512³ floats = 512 MiB; anything larger is refused
  static constexpr int kMaxCellsSize = 64;  // largest lattice with a cell table (4.4 MB at 64)

  // Throws std::invalid_argument for a size outside [2, kMaxSize] or an unknown version.
  Noise(std::uint64_t seed, int size = 64, int version = kDefaultVersion);

  // Version 2's 32-bit key of a seed, and its value of texel index i plus one: an exact float in
  // [1, 2) (the lattice value is that minus 1). Version 2 blends these biased values and takes
  // the 1 off the blend, one subtraction per lookup instead of eight.
  static std::uint32_t hash_key(std::uint64_t seed);
  static constexpr std::uint32_t kHashM1 = 0x21f0aaadu, kHashM2 = 0x735a2d97u;
  static float hash_biased(std::uint32_t key, std::uint32_t index) {
    // (index + key)·m1, the high half folded down, times m2: the top bits depend on every input
    // bit. Written as (index·m1 + key·m1) the first product splits into a part per axis.
    std::uint32_t h = (index + key) * kHashM1;
    h ^= h >> 16;
    h *= kHashM2;
    // The top 23 bits as the mantissa of a float in [1, 2).
    const std::uint32_t bits = (h >> 9) | 0x3f800000u;
    float v;
    static_assert(sizeof v == sizeof bits, "float is 32-bit");
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }

  int version() const { return version_; }
  std::uint32_t key() const { return key_; }  // hash_key(seed) (used by version 2 only)
  int size() const { return size_; }
  // Whether the lattice has its cell table (power-of-two sizes up to kMaxCellsSize), which the
  // wide kernels' Cells fetch reads; without it that fetch reads the rows (Loads).
  bool has_cells() const { return !cells_.empty(); }
  std::uint64_t seed() const { return seed_; }
  const std::vector<float>& lattice() const { return lattice_; }  // [z][y][x]

  // Trilinear lattice value at lattice coordinate u (texels), GL texel-centre convention.
  float lattice_at(glm::vec3 u) const;

  // eq. (1): Σ_{i=1..n} w^i · lattice(s^i · f · p).
  float fbm(glm::vec3 p, const FbmParams& params) const;

  // What fbm_many read of its points, in the same pass: the largest coordinate magnitude, and
  // whether every coordinate was finite (the caller's argument check, without a second pass).
  struct PointScan {
    float max_abs = 0.0f;
    bool finite = true;
  };

  // fBm of `count` points (xyz interleaved) into `out`, on `threads` threads (0 = all), with
  // the SIMD kernel of simd_level() (simd.hpp). Bit-identical to calling fbm() on each point,
  // whatever the thread count and the SIMD level. Non-finite points give NaN; with `scan`, it
  // also receives their PointScan.
  void fbm_many(const float* points, std::size_t count, float* out, const FbmParams& params,
                int threads, PointScan* scan = nullptr) const;

  // fbm_many on the calling thread, prepared once for many short calls (a camera ray's queued
  // samples, a handful to 16 at a time): the octave tables, the kernel and the coordinate scan
  // chosen when it is made, no thread pool or interrupt poll per call. Bit-identical to
  // fbm_many(points, count, out, params, 1). The Noise must outlive it.
  class Batch {
   public:
    Batch(const Noise& noise, const FbmParams& params);  // throws std::invalid_argument
    ~Batch();
    Batch(Batch&&) noexcept;
    Batch& operator=(Batch&&) noexcept;
    void operator()(const float* points, std::size_t count, float* out) const;

   private:
    friend class Noise;  // fbm_many makes the same Plan per call
    struct Plan;
    std::unique_ptr<const Plan> plan_;
  };

 private:
  // One axis of a lookup: the wrapped index of the lower texel and the blend weight.
  void split(float x, int& index, float& weight) const;
  // Trilinear blend of the 2×2×2 texels whose lower corner is (ix, iy, iz) (already wrapped).
  float blend(int ix, int iy, int iz, float wx, float wy, float wz) const;
  // lattice_at's body, inlined into fbm().
  float lookup(glm::vec3 u) const;

  std::uint64_t seed_;
  int version_;
  std::uint32_t key_;
  int size_;
  int mask_;                    // size - 1 when size is a power of two (wrap = and), else -1
  std::vector<float> lattice_;  // size³, [z][y][x]: the public lattice
  float bias_;                  // 0 (version 1) or 1 (version 2): padded_ holds lattice + bias_
  // (size+1)³ copy whose last x, y and z planes repeat the first ones, so that the upper corner
  // of a trilinear cell is always at index + 1 / + stride and never needs a second wrap; plus
  // bias_, which every lookup takes off its blend.
  std::vector<float> padded_;
  // The cell table: floats 4i .. 4i + 3, for i = (z·p + y)·p + x, hold padded (x, y, z),
  // (x, y+1, z), (x, y, z+1) and (x, y+1, z+1), the corners of the cell's x face at x. Entry
  // i + 1 holds the face at x + 1, so the 32 bytes at 4i are the whole cell whose lower corner is
  // (x, y, z): one load for the SIMD kernels' Cells fetch. Entries at y = size or z = size are
  // never read (zero). Empty unless size is a power of two ≤ kMaxCellsSize.
  std::vector<float> cells_;
};

}  // namespace cumuli
