#include "cumuli/noise.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "cumuli/parallel.hpp"
#include "cumuli/rng.hpp"
#include "cumuli/simd.hpp"

// Speed notes. The straightforward lookup (std::floor, then `%` to wrap each of the six indices)
// spends most of its time in integer divisions. Here:
//   * the lattice is also kept padded to (size+1)³, so a cell's upper corner never wraps;
//   * a power-of-two size wraps the lower corner with an `and`;
//   * floor() is a truncation plus a correction, exact while |x| < 2²² (larger coordinates, and
//     non-finite ones, take the general path with std::floor and fmod);
//   * fbm_many works on blocks of points octave by octave. Each block goes to one of three kernels
//     chosen at run time (simd.hpp): the portable one (plain loops over arrays that the compiler
//     vectorises for the baseline SSE2), and hand-written AVX2 (8 points) and AVX-512 (16 points)
//     ones in which the lattice gathers, trilinear weights and the octave sum stay in registers.
//     The wide kernels fetch the two x-neighbours of a cell row as one 64-bit element (they are
//     adjacent in the padded lattice), so a point costs 4 fetched rows per octave instead of 8
//     corners, then split the pairs with a permute. They fetch them with gathers or, where
//     gathers are micro-coded (AMD Zen 2/3: ≈ 1.3× faster so), with plain loads; or read the
//     whole cell from a table that stores each cell's eight corners together (SimdFetch).
// Why intrinsics behind a dispatch table rather than Highway or xsimd: the kernel is ~40 lines per
// width, needs only gathers, floor, and/mul/add, and must keep the exact operation order of the
// scalar path; GCC/Clang `target` attributes give runtime dispatch in one translation unit with no
// new build dependency (Debian package) and no change to the wheel.
// Every path performs the same float operations in the same order as eq. (1) written naively, so
// results are bit-identical between fbm(), fbm_many(), any SIMD level and any thread count: the
// build uses -ffp-contract=off (no multiply-add is fused behind our back) and the wide kernels are
// compiled for "avx2" / "avx512f" without "fma" and use no FMA intrinsic.

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__)
#include <immintrin.h>
#define CUMULI_X86_KERNELS 1
#endif

#if defined(__GNUC__) && !defined(__clang__)
// GCC 12's own intrinsic headers initialise their "undefined" vectors from themselves, which
// -Wmaybe-uninitialized reports once per inlined intrinsic; nothing here reads such a value.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace cumuli {

namespace {

constexpr std::size_t kBlock = 256;

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

std::uint32_t Noise::hash_key(std::uint64_t seed) {
  return static_cast<std::uint32_t>(Rng(seed).next_u64() >> 32);
}

Noise::Noise(std::uint64_t seed, int size, int version)
    : seed_(seed),
      version_(version),
      key_(hash_key(seed)),
      size_(size),
      mask_(-1),
      bias_(version == kVersionHash ? 1.0f : 0.0f) {
  if (version != kVersionTable && version != kVersionHash)
    throw std::invalid_argument("noise version must be 1 (table) or 2 (hash), got " +
                                std::to_string(version));
  if (size < 2 || size > kMaxSize)
    throw std::invalid_argument("size must be in [2, " + std::to_string(kMaxSize) + "], got " +
                                std::to_string(size));
  if ((size & (size - 1)) == 0) mask_ = size - 1;
  const std::size_t s = static_cast<std::size_t>(size);
  lattice_.resize(s * s * s);
  if (version == kVersionTable) {
    Rng rng(seed);
    for (auto& v : lattice_) v = rng.uniform();
  } else {
    for (std::size_t i = 0; i < lattice_.size(); ++i)
      lattice_[i] = hash_biased(key_, static_cast<std::uint32_t>(i)) - 1.0f;  // exact
  }

  const std::size_t p = s + 1;
  padded_.resize(p * p * p);
  for (std::size_t z = 0; z < p; ++z)
    for (std::size_t y = 0; y < p; ++y)
      for (std::size_t x = 0; x < p; ++x)
        padded_[(z * p + y) * p + x] = lattice_[((z % s) * s + (y % s)) * s + (x % s)] + bias_;
  // 4.4 MB at the default size 64; larger lattices (and sizes that are not powers of two, which
  // never reach the SIMD kernels) go without, and their Cells fetch reads the rows (Loads). The
  // hash version's wide kernels read no table.
  if (mask_ < 0 || size > kMaxCellsSize || version == kVersionHash) return;
  const std::size_t pp = p * p;
  cells_.assign(4 * pp * p, 0.0f);
  for (std::size_t z = 0; z < s; ++z)
    for (std::size_t y = 0; y < s; ++y)
      for (std::size_t x = 0; x < p; ++x) {
        const std::size_t i = (z * p + y) * p + x;
        cells_[4 * i] = padded_[i];
        cells_[4 * i + 1] = padded_[i + p];
        cells_[4 * i + 2] = padded_[i + pp];
        cells_[4 * i + 3] = padded_[i + pp + p];
      }
}

namespace {

// Noise::split beyond the fast range: |x| ≥ 2²² or not finite (out of line: rare).
__attribute__((noinline)) void split_far(float x, int size, int& index, float& weight) {
  if (!std::isfinite(x)) {  // NaN in, NaN out (through the weight), without undefined casts
    index = 0;
    weight = x - x;
    return;
  }
  // |x| >= 2^22: x is an integer-valued float far beyond int range; reduce it in double, which
  // is exact (fmod is exact and every such float is an integer).
  const double f = std::floor(static_cast<double>(x));
  weight = x - static_cast<float>(f);
  double r = std::fmod(f, static_cast<double>(size));
  if (r < 0.0) r += size;
  index = static_cast<int>(r);
}

}  // namespace

// split, blend and lattice_at are inlined into fbm(), the per-sample path of the marchers and the
// light passes (a call per octave and axis cost about a third of its time).
__attribute__((always_inline)) inline void Noise::split(float x, int& index, float& weight) const {
  if (std::fabs(x) < kFastLimit) {
    const float f = floor_small(x);
    weight = x - f;
    const int i = static_cast<int>(f);
    index = mask_ >= 0 ? (i & mask_) : wrap_mod(i, size_);
    return;
  }
  split_far(x, size_, index, weight);
}

__attribute__((always_inline)) inline float Noise::blend(int ix, int iy, int iz, float wx, float wy,
                                                         float wz) const {
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
  return (c0 + wz * (c1 - c0)) - bias_;  // x − 0 is x: version 1 unchanged
}

__attribute__((always_inline)) inline float Noise::lookup(glm::vec3 u) const {
  const glm::vec3 x = u - 0.5f;
  int ix, iy, iz;
  float wx, wy, wz;
  split(x.x, ix, wx);
  split(x.y, iy, wy);
  split(x.z, iz, wz);
  return blend(ix, iy, iz, wx, wy, wz);
}

float Noise::lattice_at(glm::vec3 u) const { return lookup(u); }

float Noise::fbm(glm::vec3 p, const FbmParams& params) const {
  float sum = 0.0f;
  float amplitude = 1.0f;
  float scale = params.frequency;
  for (int i = 1; i <= params.octaves; ++i) {
    amplitude *= params.gain;
    scale *= params.lacunarity;
    sum += amplitude * lookup(p * scale);
  }
  return sum;
}

namespace {

// Octave amplitudes and scales, accumulated exactly as Noise::fbm() does.
struct FbmTables {
  int octaves = 0;
  float amplitude[16] = {};
  float scale[16] = {};
  float max_scale = 0.0f;
};

FbmTables make_tables(const FbmParams& params) {
  FbmTables t;
  t.octaves = std::min(params.octaves, 16);
  float a = 1.0f, s = params.frequency;
  for (int o = 0; o < t.octaves; ++o) {
    a *= params.gain;
    s *= params.lacunarity;
    t.amplitude[o] = a;
    t.scale[o] = s;
    t.max_scale = std::max(t.max_scale, s);
  }
  return t;
}

// What a kernel needs of the lattice: the padded (size+1)³ copy, its edge and the wrap mask.
struct Lattice {
  const float* padded;
  const float* cells;  // Noise::cells_
  int p;               // size + 1
  int mask;            // size − 1 (power-of-two sizes only reach the kernels)
  std::uint32_t key;   // Noise::key() (the hash kernels)
  float bias;          // Noise::bias_, taken off each blend
};

// The portable kernel: octave-major loops over arrays that the compiler vectorises for the
// baseline ISA (SSE2 on x86-64). `count` ≤ kBlock points on the fast path.
void kernel_scalar(const Lattice& lat, const FbmTables& t, const float* points, std::size_t count,
                   float* out) {
  alignas(32) float px[kBlock], py[kBlock], pz[kBlock], sum[kBlock];
  alignas(32) float wx[kBlock], wy[kBlock], wz[kBlock];
  alignas(32) int base[kBlock];
  alignas(32) float k000[kBlock], k100[kBlock], k010[kBlock], k110[kBlock];
  alignas(32) float k001[kBlock], k101[kBlock], k011[kBlock], k111[kBlock];
  for (std::size_t i = 0; i < count; ++i) {
    px[i] = points[3 * i];
    py[i] = points[3 * i + 1];
    pz[i] = points[3 * i + 2];
    sum[i] = 0.0f;
  }
  const int p = lat.p;
  const int mask = lat.mask;
  for (int o = 0; o < t.octaves; ++o) {
    const float sc = t.scale[o];
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
      const float* c = lat.padded + base[i];
      k000[i] = c[0], k100[i] = c[1], k010[i] = c[pu], k110[i] = c[pu + 1];
      k001[i] = c[pp], k101[i] = c[pp + 1], k011[i] = c[pp + pu], k111[i] = c[pp + pu + 1];
    }
    const float amp = t.amplitude[o];
    for (std::size_t i = 0; i < count; ++i) {
      const float c00 = k000[i] + wx[i] * (k100[i] - k000[i]);
      const float c10 = k010[i] + wx[i] * (k110[i] - k010[i]);
      const float c01 = k001[i] + wx[i] * (k101[i] - k001[i]);
      const float c11 = k011[i] + wx[i] * (k111[i] - k011[i]);
      const float c0 = c00 + wy[i] * (c10 - c00);
      const float c1 = c01 + wy[i] * (c11 - c01);
      sum[i] += amp * ((c0 + wz[i] * (c1 - c0)) - lat.bias);
    }
  }
  std::copy(sum, sum + count, out);
}

#ifdef CUMULI_X86_KERNELS

// The wide kernels compute a cell's lower-corner index base = (iz·p + iy)·p + ix with one
// multiply-add of 16-bit pairs when p² fits in int16 (lattice sizes up to 180, the default 64
// included), else with two 32-bit multiplies; either gives the same integer.
constexpr int kMaxMaddSize = 180;

// --- AVX2: 8 points per register, two registers (16 points) in flight -------------------------

struct Avx2Consts {
  __m256 half;
  __m256i mask, p, pmul;
  std::ptrdiff_t row_offset[4];  // floats from a cell's lower corner to rows y1, z1 and y1z1
  const float* cells;            // Lattice::cells
};

// Cell faces q[j] = (e0, e1, e2, e3) of points j and j + 4 (one per 128-bit half) to one register
// per element, points in order. Two rounds of unpacks, within each 128-bit half.
__attribute__((target("avx2"), always_inline)) inline void transpose_faces_avx2(
    const __m256 q[4], __m256& e0, __m256& e1, __m256& e2, __m256& e3) {
  const __m256 t0 = _mm256_unpacklo_ps(q[0], q[1]), t1 = _mm256_unpackhi_ps(q[0], q[1]);
  const __m256 t2 = _mm256_unpacklo_ps(q[2], q[3]), t3 = _mm256_unpackhi_ps(q[2], q[3]);
  const __m256d d0 = _mm256_castps_pd(t0), d1 = _mm256_castps_pd(t1);
  const __m256d d2 = _mm256_castps_pd(t2), d3 = _mm256_castps_pd(t3);
  e0 = _mm256_castpd_ps(_mm256_unpacklo_pd(d0, d2));
  e1 = _mm256_castpd_ps(_mm256_unpackhi_pd(d0, d2));
  e2 = _mm256_castpd_ps(_mm256_unpacklo_pd(d1, d3));
  e3 = _mm256_castpd_ps(_mm256_unpackhi_pd(d1, d3));
}

// One octave of 8 points at lattice scale `sc`: kernel_scalar's arithmetic, operation for
// operation. The cell's corners are read as Fetch says (see SimdFetch): Cells loads the two
// 16-byte faces (x0, x1) of each point's cell and transposes them; Gather and Loads fetch, per
// row of the cell (y0/y1 × z0/z1), the pairs (c[x0], c[x0 + 1]) of the 8 points as 64-bit
// elements (two 4-element gathers, or eight plain loads from the indices stored to memory) and
// split the pairs into the two corners with shuffles.
template <bool Madd, SimdFetch Fetch>
__attribute__((target("avx2"), always_inline)) inline __m256 octave_avx2(const Avx2Consts& k,
                                                                         const double* lattice,
                                                                         __m256 px, __m256 py,
                                                                         __m256 pz, __m256 sc) {
  const __m256 x = _mm256_sub_ps(_mm256_mul_ps(px, sc), k.half);
  const __m256 y = _mm256_sub_ps(_mm256_mul_ps(py, sc), k.half);
  const __m256 z = _mm256_sub_ps(_mm256_mul_ps(pz, sc), k.half);
  const __m256 fx = _mm256_floor_ps(x), fy = _mm256_floor_ps(y), fz = _mm256_floor_ps(z);
  const __m256 wx = _mm256_sub_ps(x, fx), wy = _mm256_sub_ps(y, fy), wz = _mm256_sub_ps(z, fz);
  const __m256i ix = _mm256_and_si256(_mm256_cvttps_epi32(fx), k.mask);
  const __m256i iy = _mm256_and_si256(_mm256_cvttps_epi32(fy), k.mask);
  const __m256i iz = _mm256_and_si256(_mm256_cvttps_epi32(fz), k.mask);
  __m256i base;
  if (Madd) {  // iy·p + iz·p² from the 16-bit pair (iy, iz)
    const __m256i yz = _mm256_or_si256(_mm256_slli_epi32(iz, 16), iy);
    base = _mm256_add_epi32(_mm256_madd_epi16(yz, k.pmul), ix);
  } else {
    base = _mm256_add_epi32(
        _mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(iz, k.p), iy), k.p), ix);
  }
  // The four rows of the cell share the index vector: each reads from the lattice moved by its
  // row's offset (a scalar base address) instead of adding the offset to every index.
  __m256 k0[4], k1[4];  // lower / upper x corner of rows (y0,z0), (y1,z0), (y0,z1), (y1,z1)
  alignas(32) int index[8];
  if (Fetch == SimdFetch::Cells) {
    // Float offsets of the points' cells. A cell is its x0 face then its x1 face, each the rows
    // (y0,z0), (y1,z0), (y0,z1), (y1,z1) in order.
    alignas(32) std::uint32_t offset[8];  // unsigned: no sign extension in the addresses
    _mm256_store_si256(reinterpret_cast<__m256i*>(offset), _mm256_slli_epi32(base, 2));
    // q[side][j]: the x0 / x1 faces of points j | j + 4; each point's two faces are read
    // together (adjacent 16 bytes), so its offset is used once and then dead.
    __m256 q[2][4];
    for (int j = 0; j < 4; ++j)
      for (int side = 0; side < 2; ++side) {
        const float* faces = k.cells + 4 * side;
        q[side][j] = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_loadu_ps(faces + offset[j])),
                                          _mm_loadu_ps(faces + offset[j + 4]), 1);
      }
    transpose_faces_avx2(q[0], k0[0], k0[1], k0[2], k0[3]);
    transpose_faces_avx2(q[1], k1[0], k1[1], k1[2], k1[3]);
  }
  if (Fetch == SimdFetch::Loads) _mm256_store_si256(reinterpret_cast<__m256i*>(index), base);
  for (int r = 0; r < 4 && Fetch != SimdFetch::Cells; ++r) {
    const float* row_floats = reinterpret_cast<const float*>(lattice) + k.row_offset[r];
    // a: pairs of points 0..3, b: of points 4..7, as [p0 p1 | p2 p3] in 128-bit halves.
    __m256 a, b;
    if (Fetch == SimdFetch::Loads) {
      const auto pair = [row_floats](__m128d v, int i, bool high) {
        const double* at = reinterpret_cast<const double*>(row_floats + i);
        return high ? _mm_loadh_pd(v, at) : _mm_loadl_pd(v, at);
      };
      const __m128d zero = _mm_setzero_pd();
      const __m128d q0 = pair(pair(zero, index[0], false), index[1], true);
      const __m128d q1 = pair(pair(zero, index[2], false), index[3], true);
      const __m128d q2 = pair(pair(zero, index[4], false), index[5], true);
      const __m128d q3 = pair(pair(zero, index[6], false), index[7], true);
      a = _mm256_castpd_ps(_mm256_set_m128d(q1, q0));
      b = _mm256_castpd_ps(_mm256_set_m128d(q3, q2));
    } else {
      const double* row = reinterpret_cast<const double*>(row_floats);
      a = _mm256_castpd_ps(_mm256_i32gather_pd(row, _mm256_castsi256_si128(base), 4));
      b = _mm256_castpd_ps(_mm256_i32gather_pd(row, _mm256_extracti128_si256(base, 1), 4));
    }
    const __m256 lo = _mm256_shuffle_ps(a, b, _MM_SHUFFLE(2, 0, 2, 0));  // points 0 1 4 5 | 2 3 6 7
    const __m256 hi = _mm256_shuffle_ps(a, b, _MM_SHUFFLE(3, 1, 3, 1));
    k0[r] = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(lo), _MM_SHUFFLE(3, 1, 2, 0)));
    k1[r] = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(hi), _MM_SHUFFLE(3, 1, 2, 0)));
  }
  const __m256 c00 = _mm256_add_ps(k0[0], _mm256_mul_ps(wx, _mm256_sub_ps(k1[0], k0[0])));
  const __m256 c10 = _mm256_add_ps(k0[1], _mm256_mul_ps(wx, _mm256_sub_ps(k1[1], k0[1])));
  const __m256 c01 = _mm256_add_ps(k0[2], _mm256_mul_ps(wx, _mm256_sub_ps(k1[2], k0[2])));
  const __m256 c11 = _mm256_add_ps(k0[3], _mm256_mul_ps(wx, _mm256_sub_ps(k1[3], k0[3])));
  const __m256 c0 = _mm256_add_ps(c00, _mm256_mul_ps(wy, _mm256_sub_ps(c10, c00)));
  const __m256 c1 = _mm256_add_ps(c01, _mm256_mul_ps(wy, _mm256_sub_ps(c11, c01)));
  return _mm256_add_ps(c0, _mm256_mul_ps(wz, _mm256_sub_ps(c1, c0)));
}

// Points [first, first + 8·Groups) of a block (those past `count` are computed from zeros and
// not stored), Groups registers in flight to overlap the gathers' latency.
// x, y, z of 8 interleaved points (24 floats; `n` < 8 of them at the tail, the rest read as 0):
// blends pick each component's lanes from the three loads, a permute puts them in point order.
__attribute__((target("avx2"), always_inline)) inline void deinterleave8(const float* xyz,
                                                                         std::size_t n, __m256& x,
                                                                         __m256& y, __m256& z) {
  __m256 a, b, c;
  if (n >= 8) {
    a = _mm256_loadu_ps(xyz);
    b = _mm256_loadu_ps(xyz + 8);
    c = _mm256_loadu_ps(xyz + 16);
  } else {
    // Lane l of a load from float `from` is read when from + l < 3n.
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const int floats = 3 * static_cast<int>(n);
    a = _mm256_maskload_ps(xyz, _mm256_cmpgt_epi32(_mm256_set1_epi32(floats), lane));
    b = _mm256_maskload_ps(xyz + 8, _mm256_cmpgt_epi32(_mm256_set1_epi32(floats - 8), lane));
    c = _mm256_maskload_ps(xyz + 16, _mm256_cmpgt_epi32(_mm256_set1_epi32(floats - 16), lane));
  }
  // Point l's component k is float 3l + k: lane (3l + k) mod 8 of a, b or c.
  x = _mm256_permutevar8x32_ps(_mm256_blend_ps(_mm256_blend_ps(a, b, 0x92), c, 0x24),
                               _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5));
  y = _mm256_permutevar8x32_ps(_mm256_blend_ps(_mm256_blend_ps(a, b, 0x24), c, 0x49),
                               _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6));
  z = _mm256_permutevar8x32_ps(_mm256_blend_ps(_mm256_blend_ps(a, b, 0x49), c, 0x92),
                               _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7));
}

// Points [first, first + 8·Groups) of a block (those past `count` are computed from zeros and
// not stored), Groups registers in flight to overlap the lattice reads' latency.
// `octave(px, py, pz, scale)` is one octave's lattice value of 8 points (a table or hash octave).
template <class Octave, int Groups>
__attribute__((target("avx2"), always_inline)) inline void groups_avx2(
    const Octave& octave, const FbmTables& t, const float* points, std::size_t first,
    std::size_t count, float* out) {
  __m256 px[Groups], py[Groups], pz[Groups], sum[Groups];
  for (int g = 0; g < Groups; ++g) {
    const std::size_t at = first + 8 * static_cast<std::size_t>(g);
    const std::size_t n = at < count ? std::min<std::size_t>(8, count - at) : 0;
    deinterleave8(points + 3 * std::min(at, count), n, px[g], py[g], pz[g]);
    sum[g] = _mm256_setzero_ps();
  }
  for (int o = 0; o < t.octaves; ++o) {
    const __m256 sc = _mm256_set1_ps(t.scale[o]);
    const __m256 amp = _mm256_set1_ps(t.amplitude[o]);
    for (int g = 0; g < Groups; ++g)
      sum[g] = _mm256_add_ps(sum[g], _mm256_mul_ps(amp, octave(px[g], py[g], pz[g], sc)));
  }
  for (int g = 0; g < Groups; ++g) {
    const std::size_t at = first + 8 * static_cast<std::size_t>(g);
    if (at >= count) break;
    const std::size_t n = std::min<std::size_t>(8, count - at);
    if (n == 8) {
      _mm256_storeu_ps(out + at, sum[g]);
    } else {
      const __m256i keep = _mm256_cmpgt_epi32(_mm256_set1_epi32(static_cast<int>(n)),
                                              _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
      _mm256_maskstore_ps(out + at, keep, sum[g]);
    }
  }
}

// The table octave of octave_avx2 as groups_avx2's `octave`.
template <bool Madd, SimdFetch Fetch>
struct TableOctaveAvx2 {
  const Avx2Consts& k;
  const double* lattice;
  __attribute__((target("avx2"), always_inline)) __m256 operator()(__m256 px, __m256 py, __m256 pz,
                                                                   __m256 sc) const {
    return octave_avx2<Madd, Fetch>(k, lattice, px, py, pz, sc);
  }
};

// Two registers (16 points) at a time; a tail of at most 8 points takes one, not two.
template <class Octave>
__attribute__((target("avx2"), always_inline)) inline void blocks_avx2(
    const Octave& octave, const FbmTables& t, const float* points, std::size_t count, float* out) {
  for (std::size_t first = 0; first < count; first += 16) {
    if (count - first > 8)
      groups_avx2<Octave, 2>(octave, t, points, first, count, out);
    else
      groups_avx2<Octave, 1>(octave, t, points, first, count, out);
  }
}

template <bool Madd, SimdFetch Fetch>
__attribute__((target("avx2"))) void kernel_avx2(const Lattice& lat, const FbmTables& t,
                                                 const float* points, std::size_t count,
                                                 float* out) {
  const int pp = lat.p * lat.p;
  const Avx2Consts k{_mm256_set1_ps(0.5f),       _mm256_set1_epi32(lat.mask),
                     _mm256_set1_epi32(lat.p),   _mm256_set1_epi32((pp << 16) | lat.p),
                     {0, lat.p, pp, pp + lat.p}, lat.cells};
  const double* lattice = reinterpret_cast<const double*>(lat.padded);
  blocks_avx2(TableOctaveAvx2<Madd, Fetch>{k, lattice}, t, points, count, out);
}

// Version 2's biased lattice values (Noise::hash_biased) of 8 texels from their (index + key)·m1.
struct HashAvx2 {
  __m256i m1, m2, exponent;
  __m256 one;
  __attribute__((target("avx2"), always_inline)) __m256 operator()(__m256i h) const {
    h = _mm256_xor_si256(h, _mm256_srli_epi32(h, 16));
    h = _mm256_mullo_epi32(h, m2);
    return _mm256_castsi256_ps(_mm256_or_si256(_mm256_srli_epi32(h, 9), exponent));
  }
};

// One octave of 8 points whose cell corners are hashed, not read: kernel_scalar's arithmetic on
// the same biased corner values (texel (x, y, z) is index (z·size + y)·size + x). Its product
// (i + key)·m1 is z·(size²·m1) + y·(size·m1) + x·m1 + key·m1 (mod 2³²): one product per axis, the
// upper neighbour's the lower one's plus the axis constant, or 0 where size − 1 wraps to 0.
struct HashOctaveAvx2 {
  __m256 half;
  __m256i mask, key_m1;
  __m256i y_m1, z_m1;  // size·m1, size²·m1 (mod 2³²)
  HashAvx2 hash;
  // The upper neighbour's share from the lower one's (`lower` of texel j, `wrapped` its value
  // where j = size − 1).
  __attribute__((target("avx2"), always_inline)) __m256i upper(__m256i j, __m256i lower,
                                                               __m256i step,
                                                               __m256i wrapped) const {
    const __m256i last = _mm256_cmpeq_epi32(j, mask);
    return _mm256_blendv_epi8(_mm256_add_epi32(lower, step), wrapped, last);
  }
  __attribute__((target("avx2"), always_inline)) __m256 operator()(__m256 px, __m256 py, __m256 pz,
                                                                   __m256 sc) const {
    const __m256 x = _mm256_sub_ps(_mm256_mul_ps(px, sc), half);
    const __m256 y = _mm256_sub_ps(_mm256_mul_ps(py, sc), half);
    const __m256 z = _mm256_sub_ps(_mm256_mul_ps(pz, sc), half);
    const __m256 fx = _mm256_floor_ps(x), fy = _mm256_floor_ps(y), fz = _mm256_floor_ps(z);
    const __m256 wx = _mm256_sub_ps(x, fx), wy = _mm256_sub_ps(y, fy), wz = _mm256_sub_ps(z, fz);
    const __m256i x0 = _mm256_and_si256(_mm256_cvttps_epi32(fx), mask);
    const __m256i y0 = _mm256_and_si256(_mm256_cvttps_epi32(fy), mask);
    const __m256i z0 = _mm256_and_si256(_mm256_cvttps_epi32(fz), mask);
    const __m256i zero = _mm256_setzero_si256();
    // Each axis's share of (i + key)·m1, lower and upper neighbour; the key rides on x's.
    const __m256i xm0 = _mm256_add_epi32(_mm256_mullo_epi32(x0, hash.m1), key_m1);
    const __m256i xm1 = upper(x0, xm0, hash.m1, key_m1);
    const __m256i ym0 = _mm256_mullo_epi32(y0, y_m1);
    const __m256i ym1 = upper(y0, ym0, y_m1, zero);
    const __m256i zm0 = _mm256_mullo_epi32(z0, z_m1);
    const __m256i zm1 = upper(z0, zm0, z_m1, zero);
    const __m256i rm[4] = {_mm256_add_epi32(zm0, ym0), _mm256_add_epi32(zm0, ym1),
                           _mm256_add_epi32(zm1, ym0), _mm256_add_epi32(zm1, ym1)};
    __m256 c[4];
    for (int r = 0; r < 4; ++r) {
      const __m256 k0 = hash(_mm256_add_epi32(rm[r], xm0));
      const __m256 k1 = hash(_mm256_add_epi32(rm[r], xm1));
      c[r] = _mm256_add_ps(k0, _mm256_mul_ps(wx, _mm256_sub_ps(k1, k0)));
    }
    const __m256 c0 = _mm256_add_ps(c[0], _mm256_mul_ps(wy, _mm256_sub_ps(c[1], c[0])));
    const __m256 c1 = _mm256_add_ps(c[2], _mm256_mul_ps(wy, _mm256_sub_ps(c[3], c[2])));
    return _mm256_sub_ps(_mm256_add_ps(c0, _mm256_mul_ps(wz, _mm256_sub_ps(c1, c0))), hash.one);
  }
};

__attribute__((target("avx2"))) void kernel_hash_avx2(const Lattice& lat, const FbmTables& t,
                                                      const float* points, std::size_t count,
                                                      float* out) {
  const std::uint32_t size = static_cast<std::uint32_t>(lat.mask) + 1u;
  const HashOctaveAvx2 octave{_mm256_set1_ps(0.5f),
                              _mm256_set1_epi32(lat.mask),
                              _mm256_set1_epi32(static_cast<int>(lat.key * Noise::kHashM1)),
                              _mm256_set1_epi32(static_cast<int>(size * Noise::kHashM1)),
                              _mm256_set1_epi32(static_cast<int>(size * size * Noise::kHashM1)),
                              {_mm256_set1_epi32(static_cast<int>(Noise::kHashM1)),
                               _mm256_set1_epi32(static_cast<int>(Noise::kHashM2)),
                               _mm256_set1_epi32(0x3f800000), _mm256_set1_ps(1.0f)}};
  blocks_avx2(octave, t, points, count, out);
}

// --- AVX-512: 16 points per register, two registers (32 points) in flight ---------------------

struct Avx512Consts {
  __m512 half;
  __m512i mask, p, pmul, even, odd;
  std::ptrdiff_t row_offset[4];  // as Avx2Consts'
  const float* cells;
};

// The (c[i], c[i + 1]) pairs of a row at the 8 float indices i = index[0..7], in index order, as
// eight plain 64-bit loads (the Loads fetch of octave_avx512).
__attribute__((target("avx512f,avx512bw"), always_inline)) inline __m512 pairs8_avx512(
    const float* row_floats, const int* index) {
  __m128d q[4];
  for (int j = 0; j < 4; ++j) {
    const double* lo = reinterpret_cast<const double*>(row_floats + index[2 * j]);
    const double* hi = reinterpret_cast<const double*>(row_floats + index[2 * j + 1]);
    q[j] = _mm_loadh_pd(_mm_loadl_pd(_mm_setzero_pd(), lo), hi);  // no aligned double deref
  }
  const __m256d low = _mm256_insertf128_pd(_mm256_castpd128_pd256(q[0]), q[1], 1);
  const __m256d high = _mm256_insertf128_pd(_mm256_castpd128_pd256(q[2]), q[3], 1);
  return _mm512_castpd_ps(_mm512_insertf64x4(_mm512_castpd256_pd512(low), high, 1));
}

// Eight registers of two whole cells each (see octave_avx512's Cells fetch) to one register per
// corner. Two rounds of unpacks within 128-bit lanes leave, in u[e] (e < 4), corner e of four
// rows in lanes 0 and 2 and corner e + 4 in lanes 1 and 3; a lane shuffle of u[e] and u[e + 4]
// gathers each corner of all 16 points.
__attribute__((target("avx512f,avx512bw"), always_inline)) inline void transpose_cells_avx512(
    const __m512 row[8], __m512 k0[4], __m512 k1[4]) {
  __m512 u[8];
  for (int h = 0; h < 8; h += 4) {
    const __m512d t0 = _mm512_castps_pd(_mm512_unpacklo_ps(row[h], row[h + 1]));
    const __m512d t1 = _mm512_castps_pd(_mm512_unpackhi_ps(row[h], row[h + 1]));
    const __m512d t2 = _mm512_castps_pd(_mm512_unpacklo_ps(row[h + 2], row[h + 3]));
    const __m512d t3 = _mm512_castps_pd(_mm512_unpackhi_ps(row[h + 2], row[h + 3]));
    u[h] = _mm512_castpd_ps(_mm512_unpacklo_pd(t0, t2));
    u[h + 1] = _mm512_castpd_ps(_mm512_unpackhi_pd(t0, t2));
    u[h + 2] = _mm512_castpd_ps(_mm512_unpacklo_pd(t1, t3));
    u[h + 3] = _mm512_castpd_ps(_mm512_unpackhi_pd(t1, t3));
  }
  for (int e = 0; e < 4; ++e) {
    k0[e] = _mm512_shuffle_f32x4(u[e], u[e + 4], _MM_SHUFFLE(2, 0, 2, 0));
    k1[e] = _mm512_shuffle_f32x4(u[e], u[e + 4], _MM_SHUFFLE(3, 1, 3, 1));
  }
}

// As octave_avx2 for 16 points: the floor comes straight from a round-down conversion; Gather and
// Loads fetch a row's 16 pairs with two 8-element 64-bit gathers or sixteen plain loads, then
// split them into the corners with two permutes.
template <bool Madd, SimdFetch Fetch>
__attribute__((target("avx512f,avx512bw"), always_inline)) inline __m512 octave_avx512(
    const Avx512Consts& k, const double* lattice, __m512 px, __m512 py, __m512 pz, __m512 sc) {
  const __m512 x = _mm512_sub_ps(_mm512_mul_ps(px, sc), k.half);
  const __m512 y = _mm512_sub_ps(_mm512_mul_ps(py, sc), k.half);
  const __m512 z = _mm512_sub_ps(_mm512_mul_ps(pz, sc), k.half);
  // floor(x) as an integer (exact below 2²²), then as a float for the weight: the same numbers
  // as kernel_scalar's floor_small.
  constexpr int kDown = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC;
  const __m512i jx = _mm512_cvt_roundps_epi32(x, kDown);
  const __m512i jy = _mm512_cvt_roundps_epi32(y, kDown);
  const __m512i jz = _mm512_cvt_roundps_epi32(z, kDown);
  const __m512 wx = _mm512_sub_ps(x, _mm512_cvtepi32_ps(jx));
  const __m512 wy = _mm512_sub_ps(y, _mm512_cvtepi32_ps(jy));
  const __m512 wz = _mm512_sub_ps(z, _mm512_cvtepi32_ps(jz));
  const __m512i ix = _mm512_and_si512(jx, k.mask);
  const __m512i iy = _mm512_and_si512(jy, k.mask);
  const __m512i iz = _mm512_and_si512(jz, k.mask);
  __m512i base;
  if (Madd) {
    const __m512i yz = _mm512_or_si512(_mm512_slli_epi32(iz, 16), iy);
    base = _mm512_add_epi32(_mm512_madd_epi16(yz, k.pmul), ix);
  } else {
    base = _mm512_add_epi32(
        _mm512_mullo_epi32(_mm512_add_epi32(_mm512_mullo_epi32(iz, k.p), iy), k.p), ix);
  }
  alignas(64) int index[16];
  __m512 k0[4], k1[4];
  if (Fetch == SimdFetch::Cells) {
    alignas(64) std::uint32_t offset[16];  // unsigned: no sign extension in the addresses
    _mm512_store_si512(offset, _mm512_slli_epi32(base, 2));
    // One 32-byte load per point (its whole cell), two points a register: row r holds points
    // (r, r + 4) for r < 4 and (r + 4, r + 8) after, the order in which the transpose leaves the
    // points in lane order. The upper half is a masked broadcast from memory (no shuffle unit).
    __m512 row[8];
    for (int r = 0; r < 8; ++r) {
      const int a = r < 4 ? r : r + 4;
      const __m256d low = _mm256_loadu_pd(reinterpret_cast<const double*>(k.cells + offset[a]));
      const __m256d high =
          _mm256_loadu_pd(reinterpret_cast<const double*>(k.cells + offset[a + 4]));
      row[r] =
          _mm512_castpd_ps(_mm512_mask_broadcast_f64x4(_mm512_castpd256_pd512(low), 0xF0, high));
    }
    transpose_cells_avx512(row, k0, k1);
  }
  if (Fetch == SimdFetch::Loads) _mm512_store_si512(index, base);
  for (int r = 0; r < 4 && Fetch != SimdFetch::Cells; ++r) {
    const float* row_floats = reinterpret_cast<const float*>(lattice) + k.row_offset[r];
    // a: pairs of points 0..7, b: of points 8..15, in point order.
    __m512 a, b;
    if (Fetch == SimdFetch::Loads) {
      a = pairs8_avx512(row_floats, index);
      b = pairs8_avx512(row_floats, index + 8);
    } else {
      const double* row = reinterpret_cast<const double*>(row_floats);
      a = _mm512_castpd_ps(_mm512_i32gather_pd(_mm512_castsi512_si256(base), row, 4));
      b = _mm512_castpd_ps(_mm512_i32gather_pd(_mm512_extracti64x4_epi64(base, 1), row, 4));
    }
    k0[r] = _mm512_permutex2var_ps(a, k.even, b);
    k1[r] = _mm512_permutex2var_ps(a, k.odd, b);
  }
  const __m512 c00 = _mm512_add_ps(k0[0], _mm512_mul_ps(wx, _mm512_sub_ps(k1[0], k0[0])));
  const __m512 c10 = _mm512_add_ps(k0[1], _mm512_mul_ps(wx, _mm512_sub_ps(k1[1], k0[1])));
  const __m512 c01 = _mm512_add_ps(k0[2], _mm512_mul_ps(wx, _mm512_sub_ps(k1[2], k0[2])));
  const __m512 c11 = _mm512_add_ps(k0[3], _mm512_mul_ps(wx, _mm512_sub_ps(k1[3], k0[3])));
  const __m512 c0 = _mm512_add_ps(c00, _mm512_mul_ps(wy, _mm512_sub_ps(c10, c00)));
  const __m512 c1 = _mm512_add_ps(c01, _mm512_mul_ps(wy, _mm512_sub_ps(c11, c01)));
  return _mm512_add_ps(c0, _mm512_mul_ps(wz, _mm512_sub_ps(c1, c0)));
}

// x, y, z of 16 interleaved points (48 floats; `n` < 16 of them at the tail, the rest read as 0).
__attribute__((target("avx512f,avx512bw"), always_inline)) inline void deinterleave16(
    const float* xyz, std::size_t n, __m512& x, __m512& y, __m512& z) {
  __m512 a, b, c;
  if (n >= 16) {
    a = _mm512_loadu_ps(xyz);
    b = _mm512_loadu_ps(xyz + 16);
    c = _mm512_loadu_ps(xyz + 32);
  } else {
    const auto m = [](std::size_t floats) {
      return static_cast<__mmask16>(floats >= 16 ? 0xFFFFu : (1u << floats) - 1u);
    };
    const std::size_t f = 3 * n;
    a = _mm512_maskz_loadu_ps(m(f), xyz);
    b = _mm512_maskz_loadu_ps(m(f > 16 ? f - 16 : 0), xyz + 16);
    c = _mm512_maskz_loadu_ps(m(f > 32 ? f - 32 : 0), xyz + 32);
  }
  // Component k of point l is float 3l + k of a:b:c. The first permute takes those in a:b
  // (3l + k < 32), the masked second one the rest from c.
  const __m512i ab_x = _mm512_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21, 24, 27, 30, 0, 0, 0, 0, 0);
  const __m512i ab_y = _mm512_setr_epi32(1, 4, 7, 10, 13, 16, 19, 22, 25, 28, 31, 0, 0, 0, 0, 0);
  const __m512i ab_z = _mm512_setr_epi32(2, 5, 8, 11, 14, 17, 20, 23, 26, 29, 0, 0, 0, 0, 0, 0);
  const __m512i c_x = _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 17, 20, 23, 26, 29);
  const __m512i c_y = _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 18, 21, 24, 27, 30);
  const __m512i c_z = _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 16, 19, 22, 25, 28, 31);
  x = _mm512_mask_permutex2var_ps(_mm512_permutex2var_ps(a, ab_x, b), 0xF800, c_x, c);
  y = _mm512_mask_permutex2var_ps(_mm512_permutex2var_ps(a, ab_y, b), 0xF800, c_y, c);
  z = _mm512_mask_permutex2var_ps(_mm512_permutex2var_ps(a, ab_z, b), 0xFC00, c_z, c);
}

// Points [first, first + 16·Groups) of a block (those past `count` are computed from zeros and
// not stored), Groups registers in flight to overlap the gathers' latency.
template <class Octave, int Groups>
__attribute__((target("avx512f,avx512bw"), always_inline)) inline void groups_avx512(
    const Octave& octave, const FbmTables& t, const float* points, std::size_t first,
    std::size_t count, float* out) {
  __m512 px[Groups], py[Groups], pz[Groups], sum[Groups];
  for (int g = 0; g < Groups; ++g) {
    const std::size_t at = first + 16 * static_cast<std::size_t>(g);
    const std::size_t n = at < count ? std::min<std::size_t>(16, count - at) : 0;
    deinterleave16(points + 3 * std::min(at, count), n, px[g], py[g], pz[g]);
    sum[g] = _mm512_setzero_ps();
  }
  for (int o = 0; o < t.octaves; ++o) {
    const __m512 sc = _mm512_set1_ps(t.scale[o]);
    const __m512 amp = _mm512_set1_ps(t.amplitude[o]);
    for (int g = 0; g < Groups; ++g)
      sum[g] = _mm512_add_ps(sum[g], _mm512_mul_ps(amp, octave(px[g], py[g], pz[g], sc)));
  }
  for (int g = 0; g < Groups; ++g) {
    const std::size_t at = first + 16 * static_cast<std::size_t>(g);
    if (at >= count) break;
    const std::size_t n = std::min<std::size_t>(16, count - at);
    _mm512_mask_storeu_ps(out + at, static_cast<__mmask16>(n >= 16 ? 0xFFFFu : (1u << n) - 1u),
                          sum[g]);
  }
}

template <bool Madd, SimdFetch Fetch>
struct TableOctaveAvx512 {
  const Avx512Consts& k;
  const double* lattice;
  __attribute__((target("avx512f,avx512bw"), always_inline)) __m512 operator()(__m512 px, __m512 py,
                                                                               __m512 pz,
                                                                               __m512 sc) const {
    return octave_avx512<Madd, Fetch>(k, lattice, px, py, pz, sc);
  }
};

// Two registers (32 points) at a time; a tail of at most 16 points takes one, not two.
template <class Octave>
__attribute__((target("avx512f,avx512bw"), always_inline)) inline void blocks_avx512(
    const Octave& octave, const FbmTables& t, const float* points, std::size_t count, float* out) {
  for (std::size_t first = 0; first < count; first += 32) {
    if (count - first > 16)
      groups_avx512<Octave, 2>(octave, t, points, first, count, out);
    else
      groups_avx512<Octave, 1>(octave, t, points, first, count, out);
  }
}

template <bool Madd, SimdFetch Fetch>
__attribute__((target("avx512f,avx512bw"))) void kernel_avx512(const Lattice& lat,
                                                               const FbmTables& t,
                                                               const float* points,
                                                               std::size_t count, float* out) {
  const int pp = lat.p * lat.p;
  const Avx512Consts k{
      _mm512_set1_ps(0.5f),
      _mm512_set1_epi32(lat.mask),
      _mm512_set1_epi32(lat.p),
      _mm512_set1_epi32((pp << 16) | lat.p),
      // Even / odd floats of a gathered pair register couple (a, b): lane l takes 2l (2l + 1).
      _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30),
      _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31),
      {0, lat.p, pp, pp + lat.p},
      lat.cells};
  const double* lattice = reinterpret_cast<const double*>(lat.padded);
  blocks_avx512(TableOctaveAvx512<Madd, Fetch>{k, lattice}, t, points, count, out);
}

// HashAvx2 for 16 texels.
// With Shrd (CPUs with AVX512-VBMI2), (h >> 9) | exponent is one double shift, VPSHRDD, of the
// pair (h, 0x7f) right by 9: written as inline assembly, so that the kernel's target stays
// "avx512f,avx512bw" and no other instruction of VBMI2 can appear in it.
template <bool Shrd>
struct HashAvx512 {
  __m512i m1, m2, exponent;
  __m512 one;
  __m512i exponent_high;  // 0x7f: the exponent bits, 23 places below their place in the float
  __attribute__((target("avx512f,avx512bw"), always_inline)) __m512 operator()(__m512i h) const {
    h = _mm512_xor_si512(h, _mm512_srli_epi32(h, 16));
    h = _mm512_mullo_epi32(h, m2);
    if (Shrd) {
      __m512i bits;
      // AT&T order: imm, high half, low half, destination; each dword is (0x7f:h) >> 9.
      asm("vpshrdd $9, %2, %1, %0" : "=v"(bits) : "v"(h), "v"(exponent_high));
      return _mm512_castsi512_ps(bits);
    }
    return _mm512_castsi512_ps(_mm512_or_si512(_mm512_srli_epi32(h, 9), exponent));
  }
};

// HashOctaveAvx2 for 16 points (the same product per axis), with octave_avx512's round-down
// conversion for the floor. VREDUCEPS, one instruction for x − floor(x), is no substitute: where
// that difference is not exact (small negative x) it rounds otherwise than the scalar path.
template <bool Shrd>
struct HashOctaveAvx512 {
  __m512 half;
  __m512i mask, key_m1;
  __m512i y_m1, z_m1;  // size·m1, size²·m1 (mod 2³²)
  HashAvx512<Shrd> hash;
  __attribute__((target("avx512f,avx512bw"), always_inline)) __m512 operator()(__m512 px, __m512 py,
                                                                               __m512 pz,
                                                                               __m512 sc) const {
    const __m512 x = _mm512_sub_ps(_mm512_mul_ps(px, sc), half);
    const __m512 y = _mm512_sub_ps(_mm512_mul_ps(py, sc), half);
    const __m512 z = _mm512_sub_ps(_mm512_mul_ps(pz, sc), half);
    constexpr int kDown = _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC;
    const __m512i jx = _mm512_cvt_roundps_epi32(x, kDown);
    const __m512i jy = _mm512_cvt_roundps_epi32(y, kDown);
    const __m512i jz = _mm512_cvt_roundps_epi32(z, kDown);
    const __m512 wx = _mm512_sub_ps(x, _mm512_cvtepi32_ps(jx));
    const __m512 wy = _mm512_sub_ps(y, _mm512_cvtepi32_ps(jy));
    const __m512 wz = _mm512_sub_ps(z, _mm512_cvtepi32_ps(jz));
    const __m512i x0 = _mm512_and_si512(jx, mask);
    const __m512i y0 = _mm512_and_si512(jy, mask);
    const __m512i z0 = _mm512_and_si512(jz, mask);
    // Each axis's share of (i + key)·m1, lower and upper neighbour; the key rides on x's.
    const __m512i xm0 = _mm512_add_epi32(_mm512_mullo_epi32(x0, hash.m1), key_m1);
    const __m512i xm1 =
        _mm512_mask_add_epi32(key_m1, _mm512_cmpneq_epi32_mask(x0, mask), xm0, hash.m1);
    const __m512i ym0 = _mm512_mullo_epi32(y0, y_m1);
    const __m512i ym1 = _mm512_maskz_add_epi32(_mm512_cmpneq_epi32_mask(y0, mask), ym0, y_m1);
    const __m512i zm0 = _mm512_mullo_epi32(z0, z_m1);
    const __m512i zm1 = _mm512_maskz_add_epi32(_mm512_cmpneq_epi32_mask(z0, mask), zm0, z_m1);
    const __m512i rm[4] = {_mm512_add_epi32(zm0, ym0), _mm512_add_epi32(zm0, ym1),
                           _mm512_add_epi32(zm1, ym0), _mm512_add_epi32(zm1, ym1)};
    __m512 c[4];
    for (int r = 0; r < 4; ++r) {
      const __m512 k0 = hash(_mm512_add_epi32(rm[r], xm0));
      const __m512 k1 = hash(_mm512_add_epi32(rm[r], xm1));
      c[r] = _mm512_add_ps(k0, _mm512_mul_ps(wx, _mm512_sub_ps(k1, k0)));
    }
    const __m512 c0 = _mm512_add_ps(c[0], _mm512_mul_ps(wy, _mm512_sub_ps(c[1], c[0])));
    const __m512 c1 = _mm512_add_ps(c[2], _mm512_mul_ps(wy, _mm512_sub_ps(c[3], c[2])));
    return _mm512_sub_ps(_mm512_add_ps(c0, _mm512_mul_ps(wz, _mm512_sub_ps(c1, c0))), hash.one);
  }
};

template <bool Shrd>
__attribute__((target("avx512f,avx512bw"))) void kernel_hash_avx512(const Lattice& lat,
                                                                    const FbmTables& t,
                                                                    const float* points,
                                                                    std::size_t count, float* out) {
  constexpr std::uint32_t kM1 = Noise::kHashM1;
  const std::uint32_t size = static_cast<std::uint32_t>(lat.mask) + 1u;
  const HashOctaveAvx512<Shrd> octave{
      _mm512_set1_ps(0.5f),
      _mm512_set1_epi32(lat.mask),
      _mm512_set1_epi32(static_cast<int>(lat.key * kM1)),
      _mm512_set1_epi32(static_cast<int>(size * kM1)),
      _mm512_set1_epi32(static_cast<int>(size * size * kM1)),
      {_mm512_set1_epi32(static_cast<int>(kM1)),
       _mm512_set1_epi32(static_cast<int>(Noise::kHashM2)), _mm512_set1_epi32(0x3f800000),
       _mm512_set1_ps(1.0f), _mm512_set1_epi32(0x7f)}};
  blocks_avx512(octave, t, points, count, out);
}

#endif  // CUMULI_X86_KERNELS

using Kernel = void (*)(const Lattice&, const FbmTables&, const float*, std::size_t, float*);

// The largest |v[j]| of n floats, as the bits of a non-negative float: their integer order is
// the float order, with inf and NaN above every finite value, so this is one integer max that
// vectorises (a float max reduction does not, because of NaN).
__attribute__((always_inline)) inline std::uint32_t max_abs_bits(const float* v, std::size_t n) {
  std::uint32_t top = 0;
  for (std::size_t j = 0; j < n; ++j) {
    std::uint32_t bits;
    std::memcpy(&bits, v + j, sizeof bits);
    top = std::max(top, bits & 0x7fffffffu);
  }
  return top;
}

std::uint32_t max_abs_bits_baseline(const float* v, std::size_t n) { return max_abs_bits(v, n); }

#ifdef CUMULI_X86_KERNELS
// SSE2 has no 32-bit integer max, so the baseline loop emulates it; AVX2 has one (≈ 1/6 of the
// time of an AVX-512 fBm call went to the baseline scan).
__attribute__((target("avx2"))) std::uint32_t max_abs_bits_avx2(const float* v, std::size_t n) {
  return max_abs_bits(v, n);
}
#endif

using MaxAbsBits = std::uint32_t (*)(const float*, std::size_t);

MaxAbsBits max_abs_bits_for(SimdLevel level) {
#ifdef CUMULI_X86_KERNELS
  if (level != SimdLevel::Scalar) return max_abs_bits_avx2;
#endif
  (void)level;
  return max_abs_bits_baseline;
}

Kernel kernel_for(SimdLevel level, SimdFetch fetch, int size, bool has_cells, bool hash) {
#ifdef CUMULI_X86_KERNELS
  // The hash version's wide kernels compute the corners (no fetch to choose).
  if (hash && level == SimdLevel::Avx512)
    return __builtin_cpu_supports("avx512vbmi2") ? kernel_hash_avx512<true>
                                                 : kernel_hash_avx512<false>;
  if (hash && level == SimdLevel::Avx2) return kernel_hash_avx2;
  const bool madd = size <= kMaxMaddSize;
  if (fetch == SimdFetch::Cells && !has_cells) fetch = SimdFetch::Loads;
  // The kernels of one level: [fetch][madd].
  using F = SimdFetch;
  if (level == SimdLevel::Avx512) {
    const Kernel kernels[3][2] = {{kernel_avx512<false, F::Gather>, kernel_avx512<true, F::Gather>},
                                  {kernel_avx512<false, F::Loads>, kernel_avx512<true, F::Loads>},
                                  {kernel_avx512<false, F::Cells>, kernel_avx512<true, F::Cells>}};
    return kernels[static_cast<int>(fetch)][madd];
  }
  if (level == SimdLevel::Avx2) {
    const Kernel kernels[3][2] = {{kernel_avx2<false, F::Gather>, kernel_avx2<true, F::Gather>},
                                  {kernel_avx2<false, F::Loads>, kernel_avx2<true, F::Loads>},
                                  {kernel_avx2<false, F::Cells>, kernel_avx2<true, F::Cells>}};
    return kernels[static_cast<int>(fetch)][madd];
  }
#endif
  (void)level;
  (void)fetch;
  (void)size;
  (void)has_cells;
  (void)hash;
  return kernel_scalar;
}

}  // namespace

// What fbm_many and Batch choose once per call or batch.
struct Noise::Batch::Plan {
  const Noise* noise;
  FbmParams params;
  FbmTables tables;
  Kernel kernel;
  // For blocks of at most kNarrow points: AVX2's kernel (8 lanes) where AVX-512's is the one,
  // which would compute 16 lanes for them (the physical march's short per-ray batches). The
  // kernels give the same bits (the same operations in the same order, lane by lane).
  Kernel narrow;
  Lattice lat;
  MaxAbsBits scan_block;

  static constexpr std::size_t kNarrow = 8;

  Plan(const Noise& n, const FbmParams& p)
      : noise(&n),
        params(p),
        tables(make_tables(p)),
        kernel(kernel_for(simd_level(), simd_fetch(), n.size_, !n.cells_.empty(),
                          n.version_ == kVersionHash)),
        narrow(simd_level() == SimdLevel::Avx512
                   ? kernel_for(SimdLevel::Avx2, simd_fetch(), n.size_, !n.cells_.empty(),
                                n.version_ == kVersionHash)
                   : kernel),
        lat{n.padded_.data(), n.cells_.data(), n.size_ + 1, n.mask_, n.key_, n.bias_},
        scan_block(max_abs_bits_for(simd_level())) {}

  // Points [0, n) of one block (n ≤ kBlock) into out; returns their largest |coordinate|'s bits
  // (max_abs_bits: ≥ 0x7f800000 when one is not finite).
  std::uint32_t block(const float* pts, std::size_t n, float* out) const {
    const std::uint32_t top = scan_block(pts, 3 * n);
    const bool finite = top < 0x7f800000u;
    float biggest;
    std::memcpy(&biggest, &top, sizeof biggest);
    // Rounded multiplication is monotonic, so |p|·max_scale bounds |p|·scale of every octave
    // and every point. A block with a point beyond the fast path (or not finite, or a lattice
    // whose size is not a power of two) takes the general per-point path.
    const bool slow = lat.mask < 0 || !finite || !(biggest * tables.max_scale < kFastLimit);
    if (slow) {
      for (std::size_t k = 0; k < n; ++k)
        out[k] = noise->fbm(glm::vec3(pts[3 * k], pts[3 * k + 1], pts[3 * k + 2]), params);
    } else {
      (n <= kNarrow ? narrow : kernel)(lat, tables, pts, n, out);
    }
    return top;
  }
};

Noise::Batch::Batch(const Noise& noise, const FbmParams& params) {
  params.validate();
  plan_ = std::make_unique<const Plan>(noise, params);
}
Noise::Batch::~Batch() = default;
Noise::Batch::Batch(Batch&&) noexcept = default;
Noise::Batch& Noise::Batch::operator=(Batch&&) noexcept = default;

void Noise::Batch::operator()(const float* points, std::size_t count, float* out) const {
  for (std::size_t i = 0; i < count; i += kBlock)
    plan_->block(points + 3 * i, std::min(kBlock, count - i), out + i);
}

void Noise::fbm_many(const float* points, std::size_t count, float* out, const FbmParams& params,
                     int threads, PointScan* scan) const {
  params.validate();
  const Batch::Plan plan(*this, params);
  // Threads take whole blocks: the loop hands out up to 32 chunks per thread, which on a short
  // call (a light ray's 64 queued samples) would otherwise be a kernel call per two points.
  const std::size_t blocks = (count + kBlock - 1) / kBlock;
  // Per block: its largest |coordinate|, NaN when one is not finite (combined after the loop, so
  // no value is shared between threads).
  std::vector<float> block_max(scan != nullptr ? blocks : 0);
  parallel_chunks(blocks, threads, [&](std::size_t block_begin, std::size_t block_end) {
    const std::size_t b = block_begin * kBlock, e = std::min(count, block_end * kBlock);
    for (std::size_t i = b; i < e; i += kBlock) {
      const std::size_t n = std::min(kBlock, e - i);
      const std::uint32_t top = plan.block(points + 3 * i, n, out + i);
      if (scan != nullptr) {
        float biggest;
        std::memcpy(&biggest, &top, sizeof biggest);
        block_max[i / kBlock] =
            top < 0x7f800000u ? biggest : std::numeric_limits<float>::quiet_NaN();
      }
    }
  });
  if (scan != nullptr) {
    *scan = PointScan{};
    for (const float m : block_max) {
      if (std::isnan(m))
        scan->finite = false;
      else
        scan->max_abs = std::max(scan->max_abs, m);
    }
  }
}

}  // namespace cumuli
