#include "cumuli/light/volume.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#if defined(__SSE2__)
#include <xmmintrin.h>
#endif

#include <glm/ext/vector_double3.hpp>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include "cumuli/parallel.hpp"
#include "cumuli/rng.hpp"

namespace cumuli {

namespace {
constexpr double kPi = 3.14159265358979323846;
const float kSqrt4Pi = static_cast<float>(std::sqrt(4.0 * kPi));

void check_order(int order) {
  if (order < 1 || order > kMaxShOrder) throw std::invalid_argument("sh_order must be in [1, 4]");
}

void check_step(float step_voxels) {
  if (!(step_voxels > 0.0f) || !std::isfinite(step_voxels))
    throw std::invalid_argument("step must be finite and > 0 (in voxels)");
}

// floor(x) for |x| < 2³¹ without a libm call (the baseline x86-64 has no rounding instruction).
inline float floor_fast(float x) {
  const float t = static_cast<float>(static_cast<int>(x));
  return t - static_cast<float>(t > x);
}

// Per-axis clamp-to-edge split of texel coordinate u (GL texel centres at i + ½).
inline void split_axis(float u, int n, int& i0, int& i1, float& f) {
  const float s = u - 0.5f;
  const float fl = std::floor(s);
  f = s - fl;
  const int i = static_cast<int>(fl);
  i0 = std::clamp(i, 0, n - 1);
  i1 = std::clamp(i + 1, 0, n - 1);
}

// Distance from p (inside the box) to the box exit along dir.
inline float exit_length(const Box& b, glm::vec3 p, glm::vec3 dir) {
  float t = INFINITY;
  for (int k = 0; k < 3; ++k) {
    if (dir[k] > 0.0f) t = std::min(t, (b.hi[k] - p[k]) / dir[k]);
    if (dir[k] < 0.0f) t = std::min(t, (b.lo[k] - p[k]) / dir[k]);
  }
  return std::max(t, 0.0f);
}

float min_voxel(const VolumeGrid& g) {
  const glm::vec3 vs = g.voxel_size();
  return std::min(vs.x, std::min(vs.y, vs.z));
}
}  // namespace

void VolumeGrid::validate() const {
  if (w < 1 || h < 1 || d < 1)
    throw std::invalid_argument("volume shape must be >= 1 on every axis");
  for (int k = 0; k < 3; ++k)
    if (!(box.hi[k] > box.lo[k]) || !std::isfinite(box.lo[k]) || !std::isfinite(box.hi[k]))
      throw std::invalid_argument("box_max must be greater than box_min on every axis (finite)");
}

void sample_trilinear(const float* vol, const VolumeGrid& g, int channels, glm::vec3 p,
                      float* out) {
  const glm::vec3 u = (p - g.box.lo) / g.voxel_size();
  int x0, x1, y0, y1, z0, z1;
  float fx, fy, fz;
  split_axis(u.x, g.w, x0, x1, fx);
  split_axis(u.y, g.h, y0, y1, fy);
  split_axis(u.z, g.d, z0, z1, fz);
  const std::size_t W = static_cast<std::size_t>(g.w), H = static_cast<std::size_t>(g.h);
  auto at = [&](int x, int y, int z) { return vol + ((z * H + y) * W + x) * channels; };
#if defined(__SSE2__)
  if (channels == 4) {
    // The physical light's (F, S.rgb) lattice: a corner's four channels are one load, and the
    // lanes do the scalar loop's operations in its order (the same values bit for bit).
    auto lerp = [](__m128 a, __m128 b, float f) {
      return _mm_add_ps(a, _mm_mul_ps(_mm_set1_ps(f), _mm_sub_ps(b, a)));
    };
    const __m128 c00 = lerp(_mm_loadu_ps(at(x0, y0, z0)), _mm_loadu_ps(at(x1, y0, z0)), fx);
    const __m128 c10 = lerp(_mm_loadu_ps(at(x0, y1, z0)), _mm_loadu_ps(at(x1, y1, z0)), fx);
    const __m128 c01 = lerp(_mm_loadu_ps(at(x0, y0, z1)), _mm_loadu_ps(at(x1, y0, z1)), fx);
    const __m128 c11 = lerp(_mm_loadu_ps(at(x0, y1, z1)), _mm_loadu_ps(at(x1, y1, z1)), fx);
    _mm_storeu_ps(out, lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz));
    return;
  }
#endif
  for (int c = 0; c < channels; ++c) {
    const float c00 = at(x0, y0, z0)[c] + fx * (at(x1, y0, z0)[c] - at(x0, y0, z0)[c]);
    const float c10 = at(x0, y1, z0)[c] + fx * (at(x1, y1, z0)[c] - at(x0, y1, z0)[c]);
    const float c01 = at(x0, y0, z1)[c] + fx * (at(x1, y0, z1)[c] - at(x0, y0, z1)[c]);
    const float c11 = at(x0, y1, z1)[c] + fx * (at(x1, y1, z1)[c] - at(x0, y1, z1)[c]);
    const float c0 = c00 + fy * (c10 - c00);
    const float c1 = c01 + fy * (c11 - c01);
    out[c] = c0 + fz * (c1 - c0);
  }
}

float sample_trilinear(const float* vol, const VolumeGrid& g, glm::vec3 p) {
  float v;
  sample_trilinear(vol, g, 1, p, &v);
  return v;
}

float optical_depth_ray(const float* vol, const VolumeGrid& g, glm::vec3 p, glm::vec3 dir,
                        float step_voxels) {
  Interval span;
  if (!intersect(g.box, p, 1.0f / dir, span) || span.t_out <= 0.0f) return 0.0f;
  const float t0 = std::max(span.t_in, 0.0f);
  const float len = span.t_out - t0;
  if (len <= 0.0f) return 0.0f;
  const glm::vec3 vs = g.voxel_size();
  const float dt = step_voxels * std::min(vs.x, std::min(vs.y, vs.z));
  const int n = std::max(1, static_cast<int>(std::ceil(len / dt)));
  const float h = len / static_cast<float>(n);
  double sum = 0.0;
  for (int i = 0; i < n; ++i) sum += sample_trilinear(vol, g, p + (t0 + (i + 0.5f) * h) * dir);
  return static_cast<float>(sum * h);
}

namespace {

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__GLIBC__)
#define CUMULI_VEC_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define CUMULI_VEC_CLONES
#endif

// row[k] += h · trilinear at lines k ∈ [k0, k1) of one sweep row whose lower corners sit at
// consecutive indices b0 = first + k (no clamping needed): contiguous loads, a vector loop.
// Compiled for the baseline and AVX2 / AVX-512 (same IEEE operations, so the same bits).
CUMULI_VEC_CLONES void sweep_row(float* row, std::size_t k0, std::size_t k1, const float* s0c0,
                                 const float* s0c1, const float* s1c0, const float* s1c1, float wa,
                                 float wb, float wc, float h) {
  for (std::size_t k = k0; k < k1; ++k) {
    const float p00 = s0c0[k] + wb * (s0c0[k + 1] - s0c0[k]);
    const float p01 = s0c1[k] + wb * (s0c1[k + 1] - s0c1[k]);
    const float q00 = s1c0[k] + wb * (s1c0[k + 1] - s1c0[k]);
    const float q01 = s1c1[k] + wb * (s1c1[k + 1] - s1c1[k]);
    const float r0 = p00 + wc * (p01 - p00), r1 = q00 + wc * (q01 - q00);
    row[k] += h * (r0 + wa * (r1 - r0));
  }
}

}  // namespace

std::vector<float> transpose_yzx(const float* vol, const VolumeGrid& g) {
  std::vector<float> out(g.voxels());
  const std::size_t W = static_cast<std::size_t>(g.w), H = static_cast<std::size_t>(g.h),
                    D = static_cast<std::size_t>(g.d);
  for (std::size_t z = 0; z < D; ++z)
    for (std::size_t y = 0; y < H; ++y)
      for (std::size_t x = 0; x < W; ++x) out[(x * D + z) * H + y] = vol[(z * H + y) * W + x];
  return out;
}

void sweep_optical_depth(const float* vol, const VolumeGrid& g, glm::vec3 dir, float step_voxels,
                         float* f, std::vector<float>& phi, const float* vol_yzx) {
  const glm::vec3 vs = g.voxel_size();
  const int n[3] = {g.w, g.h, g.d};
  const std::size_t st[3] = {1, static_cast<std::size_t>(g.w),
                             static_cast<std::size_t>(g.w) * static_cast<std::size_t>(g.h)};
  const glm::vec3 e = dir / vs;  // index units per unit length
  int a = 0;
  for (int k = 1; k < 3; ++k)
    if (std::fabs(e[k]) > std::fabs(e[a])) a = k;
  // Lateral axes: b the one with the smaller stride (the inner loop), c the other. Layers across
  // x read the [x][z][y] copy, if given, so that b = y is contiguous there too.
  const int b = a == 0 ? 1 : 0, c = a == 2 ? 1 : 2;
  const float* src = vol;
  std::size_t vst[3] = {st[0], st[1], st[2]};
  if (a == 0 && vol_yzx != nullptr) {
    src = vol_yzx;
    vst[1] = 1;
    vst[2] = static_cast<std::size_t>(g.h);
    vst[0] = static_cast<std::size_t>(g.h) * static_cast<std::size_t>(g.d);
  }
  const int na = n[a], nb = n[b], nc = n[c];
  const int sgn = e[a] > 0.0f ? 1 : -1;
  const float lambda = 1.0f / std::fabs(e[a]);     // ray length per layer
  const float sb = e[b] / e[a], sc = e[c] / e[a];  // index shift per layer (|s| ≤ 1)
  const float dt = step_voxels * min_voxel(g);
  // Lines: index coordinates (lb + sb·u, u, lc + sc·u) for layer coordinate u (axes b, a, c).
  const float span_b = sb * static_cast<float>(na - 1), span_c = sc * static_cast<float>(na - 1);
  const int lb0 = static_cast<int>(floor_fast(std::min(0.0f, -span_b)));
  const int lb1 =
      static_cast<int>(floor_fast(static_cast<float>(nb - 1) + std::max(0.0f, -span_b))) + 1;
  const int lc0 = static_cast<int>(floor_fast(std::min(0.0f, -span_c)));
  const int lc1 =
      static_cast<int>(floor_fast(static_cast<float>(nc - 1) + std::max(0.0f, -span_c))) + 1;
  const std::size_t Lb = static_cast<std::size_t>(lb1 - lb0 + 1),
                    Lc = static_cast<std::size_t>(lc1 - lc0 + 1);
  const std::size_t lines = Lb * Lc;
  // On layer j, the lines a voxel or its ray can read lie within 2 voxels of the voxel range
  // sideways (the ray leaves the box half a voxel out, its lines one voxel further).
  struct Range {
    std::size_t c_lo, c_hi, b_lo, b_hi;
  };
  const auto axis_range = [](float shift, int lo_line, int count, std::size_t L, std::size_t& k_lo,
                             std::size_t& k_hi) {
    const int first = static_cast<int>(floor_fast(-2.5f - shift)) - lo_line;
    const int last =
        -static_cast<int>(floor_fast(-(static_cast<float>(count) + 1.5f - shift))) - lo_line;
    k_lo = static_cast<std::size_t>(std::clamp(first, 0, static_cast<int>(L)));
    k_hi = static_cast<std::size_t>(std::clamp(last + 1, 0, static_cast<int>(L)));
  };
  const auto range_at = [&](int j) {
    Range r{};
    axis_range(sc * static_cast<float>(j), lc0, nc, Lc, r.c_lo, r.c_hi);
    axis_range(sb * static_cast<float>(j), lb0, nb, Lb, r.b_lo, r.b_hi);
    return r;
  };
  // dst[line] += weight · ρ(line point at layer coordinate u), ρ trilinear clamped to the edges.
  const auto add_tap = [&](float* dst, float u, float weight, const Range& r) {
    const float ua = floor_fast(u), ub = floor_fast(sb * u), uc = floor_fast(sc * u);
    const float wa = u - ua, wb = sb * u - ub, wc = sc * u - uc;
    const int a0 = std::clamp(static_cast<int>(ua), 0, na - 1);
    const int a1 = std::clamp(static_cast<int>(ua) + 1, 0, na - 1);
    const int ob = static_cast<int>(ub), oc = static_cast<int>(uc);
    const float* s0 = src + static_cast<std::size_t>(a0) * vst[a];
    const float* s1 = src + static_cast<std::size_t>(a1) * vst[a];
    // Lines whose lower b corner lb + ob is in [0, nb − 2] need no clamping.
    const std::size_t in_lo =
        static_cast<std::size_t>(std::clamp(-ob - lb0, 0, static_cast<int>(Lb)));
    const std::size_t in_hi =
        static_cast<std::size_t>(std::clamp(nb - 1 - ob - lb0, 0, static_cast<int>(Lb)));
    for (std::size_t kc = r.c_lo; kc < r.c_hi; ++kc) {
      const int lc = lc0 + static_cast<int>(kc);
      const std::size_t c0 = static_cast<std::size_t>(std::clamp(lc + oc, 0, nc - 1)) * vst[c];
      const std::size_t c1 = static_cast<std::size_t>(std::clamp(lc + oc + 1, 0, nc - 1)) * vst[c];
      float* row = dst + kc * Lb;
      const auto clamped = [&](std::size_t kb) {
        const int lb = lb0 + static_cast<int>(kb);
        const std::size_t b0 = static_cast<std::size_t>(std::clamp(lb + ob, 0, nb - 1)) * vst[b];
        const std::size_t b1 =
            static_cast<std::size_t>(std::clamp(lb + ob + 1, 0, nb - 1)) * vst[b];
        const float p00 = s0[b0 + c0] + wb * (s0[b1 + c0] - s0[b0 + c0]);
        const float p01 = s0[b0 + c1] + wb * (s0[b1 + c1] - s0[b0 + c1]);
        const float q00 = s1[b0 + c0] + wb * (s1[b1 + c0] - s1[b0 + c0]);
        const float q01 = s1[b0 + c1] + wb * (s1[b1 + c1] - s1[b0 + c1]);
        const float r0 = p00 + wc * (p01 - p00), r1 = q00 + wc * (q01 - q00);
        row[kb] += weight * (r0 + wa * (r1 - r0));
      };
      const std::size_t mid_lo = std::max(r.b_lo, in_lo), mid_hi = std::min(r.b_hi, in_hi);
      if (vst[b] == 1 && mid_lo < mid_hi) {
        for (std::size_t kb = r.b_lo; kb < mid_lo; ++kb) clamped(kb);
        // Interior: the lower corner of line kb is at index lb0 + ob + kb.
        const std::ptrdiff_t shift = static_cast<std::ptrdiff_t>(lb0 + ob);
        sweep_row(row, mid_lo, mid_hi, s0 + c0 + shift, s0 + c1 + shift, s1 + c0 + shift,
                  s1 + c1 + shift, wa, wb, wc, weight);
        for (std::size_t kb = mid_hi; kb < r.b_hi; ++kb) clamped(kb);
      } else {
        for (std::size_t kb = r.b_lo; kb < r.b_hi; ++kb) clamped(kb);
      }
    }
  };
  // phi[j][line]: ∫ ρ along the line from layer j to the box face on the exit side (density
  // clamped at the edges), up to a constant per line: only differences along a line are read.
  // Composite Simpson between consecutive layers, panels ≤ 8·step voxels long: the end points lie
  // on the layers (values shared by the two intervals of a layer), the others between.
  phi.assign(lines * static_cast<std::size_t>(na), 0.0f);
  std::vector<float> plane_prev(lines, 0.0f), plane_cur(lines, 0.0f);
  const float face = sgn > 0 ? static_cast<float>(na) - 0.5f : -0.5f;
  for (int step = 0; step < na; ++step) {
    const int j = sgn > 0 ? na - 1 - step : step;
    const float from = step == 0 ? face : static_cast<float>(j + sgn);  // the exit side end
    const float span = std::fabs(from - static_cast<float>(j));
    const int panels = std::max(1, -static_cast<int>(floor_fast(-span * lambda / (8.0f * dt))));
    const float w = span * lambda / (6.0f * static_cast<float>(panels));
    float* pj = phi.data() + static_cast<std::size_t>(j) * lines;
    const Range r = range_at(j);
    if (step == 0) {
      std::fill(plane_prev.begin(), plane_prev.end(), 0.0f);
      add_tap(plane_prev.data(), face, 1.0f, r);
    } else {
      const float* prev = phi.data() + static_cast<std::size_t>(j + sgn) * lines;
      std::copy(prev, prev + lines, pj);
    }
    for (int i = 1; i < 2 * panels; ++i) {
      const float u = static_cast<float>(j) +
                      (from - static_cast<float>(j)) * (static_cast<float>(i) / (2.0f * panels));
      add_tap(pj, u, (i % 2 ? 4.0f : 2.0f) * w, r);
    }
    // The plane values at j, for this interval and the next one (whose lines may reach one
    // layer's shift further).
    Range rc = r;
    if (step + 1 < na) {
      const Range rn = range_at(j - sgn);
      rc = Range{std::min(r.c_lo, rn.c_lo), std::max(r.c_hi, rn.c_hi), std::min(r.b_lo, rn.b_lo),
                 std::max(r.b_hi, rn.b_hi)};
    }
    std::fill(plane_cur.begin(), plane_cur.end(), 0.0f);
    add_tap(plane_cur.data(), static_cast<float>(j), 1.0f, rc);
    for (std::size_t kc = r.c_lo; kc < r.c_hi; ++kc)
      for (std::size_t kb = r.b_lo; kb < r.b_hi; ++kb) {
        const std::size_t l = kc * Lb + kb;
        pj[l] += w * (plane_prev[l] + plane_cur[l]);
      }
    plane_prev.swap(plane_cur);
  }
  // Each voxel: the four lines around it, from its layer to where its own ray leaves the box
  // (Φ linear between layers; on the exit face, half a layer past the last one). In layers, a
  // voxel at lateral index i leaves through a side face (at −½ or n − ½) after
  // (n − ½ − i)/s or (−½ − i)/s layers when its shift s per layer is non-zero.
  const auto to_side = [](float shift, int count) {
    std::vector<float> out(static_cast<std::size_t>(count), INFINITY);
    for (int i = 0; i < count; ++i) {
      if (shift > 0.0f)
        out[static_cast<std::size_t>(i)] = (static_cast<float>(count) - 0.5f - i) / shift;
      if (shift < 0.0f) out[static_cast<std::size_t>(i)] = (-0.5f - i) / shift;
    }
    return out;
  };
  const std::vector<float> to_side_b = to_side(static_cast<float>(sgn) * sb, nb);
  const std::vector<float> to_side_c = to_side(static_cast<float>(sgn) * sc, nc);
  for (int j = 0; j < na; ++j) {
    const float* pj = phi.data() + static_cast<std::size_t>(j) * lines;
    for (int ic = 0; ic < nc; ++ic) {
      const float vc = static_cast<float>(ic) - sc * static_cast<float>(j);
      const float fc = floor_fast(vc);
      const float wc = vc - fc;
      const std::size_t kc = static_cast<std::size_t>(static_cast<int>(fc) - lc0);
      for (int ib = 0; ib < nb; ++ib) {
        const float vb = static_cast<float>(ib) - sb * static_cast<float>(j);
        const float fb = floor_fast(vb);
        const float wb = vb - fb;
        const std::size_t kb = static_cast<std::size_t>(static_cast<int>(fb) - lb0);
        const std::size_t l00 = kc * Lb + kb, l10 = l00 + 1, l01 = l00 + Lb, l11 = l00 + Lb + 1;
        const auto blend = [&](const float* pl) {
          const float s0 = pl[l00] + wb * (pl[l10] - pl[l00]);
          const float s1 = pl[l01] + wb * (pl[l11] - pl[l01]);
          return s0 + wc * (s1 - s0);
        };
        const float here = blend(pj);
        // Layer coordinate of the exit: the a face unless a side face comes first.
        float ue = face;
        const float side = std::min(to_side_b[static_cast<std::size_t>(ib)],
                                    to_side_c[static_cast<std::size_t>(ic)]);
        const float along = std::fabs(face - static_cast<float>(j));  // layers to the a face
        if (side < along) ue = static_cast<float>(j) + static_cast<float>(sgn) * side;
        float at_exit = 0.0f;  // Φ = 0 on the a face by construction
        if (ue != face) {
          // The layer before the exit (towards this voxel) and the fraction beyond it.
          const int je = sgn > 0 ? std::min(static_cast<int>(floor_fast(ue)), na - 1)
                                 : std::max(static_cast<int>(-floor_fast(-ue)), 0);
          const float at = blend(phi.data() + static_cast<std::size_t>(je) * lines);
          const int jn = je + sgn;
          const float w = std::fabs(ue - static_cast<float>(je));
          if (jn >= 0 && jn < na) {
            at_exit = at + w * (blend(phi.data() + static_cast<std::size_t>(jn) * lines) - at);
          } else {  // between the last layer and the face
            at_exit = at - (w / 0.5f) * at;
          }
        }
        f[static_cast<std::size_t>(j) * st[a] + static_cast<std::size_t>(ib) * st[b] +
          static_cast<std::size_t>(ic) * st[c]] = here - at_exit;
      }
    }
  }
}

std::vector<float> sun_optical_depth(const float* volumes, int count, const VolumeGrid& g,
                                     glm::vec3 to_sun, float step_voxels, int threads,
                                     DepthMethod method) {
  g.validate();
  check_step(step_voxels);
  const float len = glm::length(to_sun);
  if (!(len > 0.0f) || !std::isfinite(len))
    throw std::invalid_argument("sun direction must be non-zero");
  const glm::vec3 dir = to_sun / len;
  const std::size_t nv = g.voxels();
  std::vector<float> out(nv * static_cast<std::size_t>(count));
  if (method == DepthMethod::Sweep) {
    // One sweep per volume; volumes in parallel.
    parallel_chunks(static_cast<std::size_t>(count), threads, [&](std::size_t b, std::size_t e) {
      std::vector<float> phi;
      for (std::size_t i = b; i < e; ++i) {
        const float* density = volumes + i * nv;
        std::vector<float> yzx;
        if (std::fabs(dir.x) / g.voxel_size().x >= std::fabs(dir.y) / g.voxel_size().y &&
            std::fabs(dir.x) / g.voxel_size().x >= std::fabs(dir.z) / g.voxel_size().z)
          yzx = transpose_yzx(density, g);
        sweep_optical_depth(density, g, dir, step_voxels, out.data() + i * nv, phi,
                            yzx.empty() ? nullptr : yzx.data());
      }
    });
    return out;
  }
  parallel_for(out.size(), threads, [&](std::size_t i) {
    const std::size_t v = i % nv;
    const int x = static_cast<int>(v % g.w), y = static_cast<int>((v / g.w) % g.h),
              z = static_cast<int>(v / (static_cast<std::size_t>(g.w) * g.h));
    out[i] = optical_depth_ray(volumes + (i / nv) * nv, g, g.centre(x, y, z), dir, step_voxels);
  });
  return out;
}

// --- spherical harmonics -------------------------------------------------------------------

void sh_eval(int order, glm::vec3 d, float* out) {
  const float x = d.x, y = d.y, z = d.z;
  out[0] = 0.282094791773878f;
  if (order < 2) return;
  out[1] = 0.488602511902920f * y;
  out[2] = 0.488602511902920f * z;
  out[3] = 0.488602511902920f * x;
  if (order < 3) return;
  out[4] = 1.092548430592079f * x * y;
  out[5] = 1.092548430592079f * y * z;
  out[6] = 0.315391565252520f * (3.0f * z * z - 1.0f);
  out[7] = 1.092548430592079f * x * z;
  out[8] = 0.546274215296040f * (x * x - y * y);
  if (order < 4) return;
  out[9] = 0.590043589926644f * y * (3.0f * x * x - y * y);
  out[10] = 2.890611442640554f * x * y * z;
  out[11] = 0.457045799464466f * y * (5.0f * z * z - 1.0f);
  out[12] = 0.373176332590115f * z * (5.0f * z * z - 3.0f);
  out[13] = 0.457045799464466f * x * (5.0f * z * z - 1.0f);
  out[14] = 1.445305721320277f * z * (x * x - y * y);
  out[15] = 0.590043589926644f * x * (x * x - 3.0f * y * y);
}

SphereQuadrature::SphereQuadrature(int n_theta) {
  if (n_theta < 1 || n_theta > 64) throw std::invalid_argument("sh_samples must be in [1, 64]");
  const int n = n_theta, m = 2 * n_theta;
  for (int i = 0; i < n; ++i) {
    // Gauss–Legendre node i by Newton's method on P_n from the Chebyshev guess.
    double mu = std::cos(kPi * (i + 0.75) / (n + 0.5)), dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = mu;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * mu * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (mu * p1 - p0) / (mu * mu - 1.0);
      const double step = p1 / dp;
      mu -= step;
      if (std::abs(step) < 1e-15) break;
    }
    const double wmu = 2.0 / ((1.0 - mu * mu) * dp * dp);
    const double s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
    for (int j = 0; j < m; ++j) {
      const double phi = 2.0 * kPi * (j + 0.5) / m;
      dirs.emplace_back(static_cast<float>(s * std::cos(phi)),
                        static_cast<float>(s * std::sin(phi)), static_cast<float>(mu));
      weights.push_back(static_cast<float>(wmu * 2.0 * kPi / m));
    }
  }
}

namespace {

// acc[v][·] += Σ_j depth[j][v] · w_j · y_j[·] for voxels [vb, ve), directions j in order (the
// sum for each coefficient runs in the same order whatever the split, so the result does not
// depend on the thread count). Compiled for the baseline and AVX2 / AVX-512.
template <int NC>
inline void project_fixed(double* acc, const float* depth, std::size_t nv, std::size_t vb,
                          std::size_t ve, std::size_t kn, const float* basis, const float* w) {
  for (std::size_t v = vb; v < ve; ++v) {
    double a[NC];
    for (int cc = 0; cc < NC; ++cc) a[cc] = acc[v * NC + cc];
    for (std::size_t j = 0; j < kn; ++j) {
      const double fw = static_cast<double>(depth[j * nv + v]) * w[j];
      for (int cc = 0; cc < NC; ++cc) a[cc] += fw * basis[j * NC + cc];
    }
    for (int cc = 0; cc < NC; ++cc) acc[v * NC + cc] = a[cc];
  }
}

CUMULI_VEC_CLONES void project_depths(double* acc, const float* depth, std::size_t nv,
                                      std::size_t vb, std::size_t ve, std::size_t kn,
                                      const float* basis, const float* w, int nc) {
  switch (nc) {
    case 1:
      project_fixed<1>(acc, depth, nv, vb, ve, kn, basis, w);
      break;
    case 4:
      project_fixed<4>(acc, depth, nv, vb, ve, kn, basis, w);
      break;
    case 9:
      project_fixed<9>(acc, depth, nv, vb, ve, kn, basis, w);
      break;
    default:
      project_fixed<16>(acc, depth, nv, vb, ve, kn, basis, w);
      break;
  }
}

}  // namespace

std::vector<float> sh_optical_depth(const float* volumes, int count, const VolumeGrid& g, int order,
                                    int n_theta, float step_voxels, int threads,
                                    DepthMethod method) {
  g.validate();
  check_order(order);
  check_step(step_voxels);
  const SphereQuadrature quad(n_theta);
  const int nc = order * order;
  std::vector<float> basis(quad.dirs.size() * nc);
  for (std::size_t k = 0; k < quad.dirs.size(); ++k) sh_eval(order, quad.dirs[k], &basis[k * nc]);
  const std::size_t nv = g.voxels();
  std::vector<float> out(nv * static_cast<std::size_t>(count) * nc);
  if (method == DepthMethod::Sweep) {
    // Per volume: sweeps along the quadrature directions, a batch of them in parallel, then each
    // voxel's projection accumulated over the batch in direction order (so the sums, hence the
    // result, do not depend on the thread count).
    const std::size_t ndir = quad.dirs.size();
    const std::size_t batch =
        std::min<std::size_t>(ndir, 2 * std::max<std::size_t>(resolve_threads(threads, ndir), 1));
    std::vector<float> depth(batch * nv);
    std::vector<std::vector<float>> phi(batch);
    std::vector<float> yzx;
    std::vector<double> acc(nv * nc);
    for (int vol = 0; vol < count; ++vol) {
      const float* density = volumes + static_cast<std::size_t>(vol) * nv;
      yzx = transpose_yzx(density, g);
      std::fill(acc.begin(), acc.end(), 0.0);
      for (std::size_t k0 = 0; k0 < ndir; k0 += batch) {
        const std::size_t kn = std::min(batch, ndir - k0);
        parallel_for(kn, threads, [&](std::size_t j) {
          sweep_optical_depth(density, g, quad.dirs[k0 + j], step_voxels, depth.data() + j * nv,
                              phi[j], yzx.data());
        });
        parallel_chunks(nv, threads, [&](std::size_t vb, std::size_t ve) {
          project_depths(acc.data(), depth.data(), nv, vb, ve, kn, &basis[k0 * nc],
                         &quad.weights[k0], nc);
        });
      }
      float* o = out.data() + static_cast<std::size_t>(vol) * nv * nc;
      for (std::size_t i = 0; i < nv * nc; ++i) o[i] = static_cast<float>(acc[i]);
    }
    return out;
  }
  parallel_for(nv * static_cast<std::size_t>(count), threads, [&](std::size_t i) {
    const std::size_t v = i % nv;
    const int x = static_cast<int>(v % g.w), y = static_cast<int>((v / g.w) % g.h),
              z = static_cast<int>(v / (static_cast<std::size_t>(g.w) * g.h));
    const glm::vec3 p = g.centre(x, y, z);
    const float* vol = volumes + (i / nv) * nv;
    double acc[kMaxShOrder * kMaxShOrder] = {};
    for (std::size_t k = 0; k < quad.dirs.size(); ++k) {
      const double f = optical_depth_ray(vol, g, p, quad.dirs[k], step_voxels) * quad.weights[k];
      for (int c = 0; c < nc; ++c) acc[c] += f * basis[k * nc + c];
    }
    for (int c = 0; c < nc; ++c) out[i * nc + c] = static_cast<float>(acc[c]);
  });
  return out;
}

std::vector<float> sky_sh(const SkyParams& sky_params, int order, int n_theta) {
  check_order(order);
  SkyParams no_disc = sky_params;
  no_disc.sun_disc_intensity = 0.0f;
  const SunParams sun;
  const SphereQuadrature quad(n_theta);
  const int nc = order * order;
  std::vector<double> acc(3 * static_cast<std::size_t>(nc), 0.0);
  float y[kMaxShOrder * kMaxShOrder];
  for (std::size_t k = 0; k < quad.dirs.size(); ++k) {
    sh_eval(order, quad.dirs[k], y);
    const glm::vec3 L3 = sky_radiance(no_disc, sun, quad.dirs[k]);
    for (int ch = 0; ch < 3; ++ch) {
      const float L = L3[ch];
      for (int c = 0; c < nc; ++c)
        acc[ch * nc + c] += static_cast<double>(L) * quad.weights[k] * y[c];
    }
  }
  return std::vector<float>(acc.begin(), acc.end());
}

std::vector<float> sh_triple(int order) {
  check_order(order);
  // Degree 3(order − 1) polynomials need n_theta ≥ (3(order − 1) + 1)/2; 2·order is enough.
  const SphereQuadrature quad(2 * order);
  const int nc = order * order;
  std::vector<double> acc(static_cast<std::size_t>(nc) * nc * nc, 0.0);
  float y[kMaxShOrder * kMaxShOrder];
  for (std::size_t q = 0; q < quad.dirs.size(); ++q) {
    sh_eval(order, quad.dirs[q], y);
    for (int i = 0; i < nc; ++i)
      for (int j = 0; j < nc; ++j)
        for (int k = 0; k < nc; ++k)
          acc[(static_cast<std::size_t>(i) * nc + j) * nc + k] +=
              static_cast<double>(quad.weights[q]) * y[i] * y[j] * y[k];
  }
  return std::vector<float>(acc.begin(), acc.end());
}

ShExpTable shexp_squaring(int order) {
  ShExpTable t;
  t.order = order;
  t.squaring = true;
  t.triple = sh_triple(order);
  t.a.assign(1, 1.0f);
  t.b.assign(1, 1.0f);
  return t;
}

namespace {
// c = projection of the product of the functions with coefficients a and b.
void sh_product(int nc, const float* triple, const double* a, const double* b, double* c) {
  for (int k = 0; k < nc; ++k) c[k] = 0.0;
  for (int i = 0; i < nc; ++i) {
    if (a[i] == 0.0) continue;
    for (int j = 0; j < nc; ++j) {
      const double ab = a[i] * b[j];
      const float* t = triple + (static_cast<std::size_t>(i) * nc + j) * nc;
      for (int k = 0; k < nc; ++k) c[k] += ab * t[k];
    }
  }
}
}  // namespace

void ShExpTable::apply(const float* g, float* out) const {
  const int nc = order * order;
  if (squaring) {
    double n2 = 0.0;
    for (int c = 1; c < nc; ++c) n2 += static_cast<double>(g[c]) * g[c];
    const double norm = std::sqrt(n2);
    int k = 0;
    while (norm / std::ldexp(1.0, k) > 0.25 && k < 40) ++k;
    const double s = std::ldexp(1.0, -k);
    double h[kMaxShOrder * kMaxShOrder]{}, e[kMaxShOrder * kMaxShOrder]{},
        tmp[kMaxShOrder * kMaxShOrder]{};
    h[0] = 0.0;
    for (int c = 1; c < nc; ++c) h[c] = s * g[c];
    sh_product(nc, triple.data(), h, h, tmp);  // exp*(ĥ) ≈ 1 + ĥ + ½ ĥ*ĥ
    for (int c = 0; c < nc; ++c) e[c] = h[c] + 0.5 * tmp[c];
    e[0] += kSqrt4Pi;
    for (int i = 0; i < k; ++i) {
      sh_product(nc, triple.data(), e, e, tmp);
      for (int c = 0; c < nc; ++c) e[c] = tmp[c];
    }
    const double scale = std::exp(static_cast<double>(g[0]) / kSqrt4Pi);
    for (int c = 0; c < nc; ++c) out[c] = static_cast<float>(scale * e[c]);
    return;
  }
  double n2 = 0.0;
  for (int c = 1; c < nc; ++c) n2 += static_cast<double>(g[c]) * g[c];
  const float norm = static_cast<float>(std::sqrt(n2));
  const int bins = static_cast<int>(a.size());
  float av = a[0], bv = b[0];
  if (bins > 1 && max_norm > 0.0f) {
    const float s = std::clamp(norm / max_norm * bins - 0.5f, 0.0f, static_cast<float>(bins - 1));
    const int i0 = std::min(static_cast<int>(s), bins - 2);
    const float f = s - static_cast<float>(i0);
    av = a[i0] + f * (a[i0 + 1] - a[i0]);
    bv = b[i0] + f * (b[i0 + 1] - b[i0]);
  }
  const float scale = std::exp(g[0] / kSqrt4Pi);
  out[0] = scale * av * kSqrt4Pi;
  for (int c = 1; c < nc; ++c) out[c] = scale * bv * g[c];
}

ShExpTable fit_shexp(const float* f, std::size_t count, int order, float sigma_t, int bins,
                     int n_theta) {
  check_order(order);
  if (bins < 1 || bins > 4096) throw std::invalid_argument("shexp_bins must be in [1, 4096]");
  if (!(sigma_t >= 0.0f) || !std::isfinite(sigma_t))
    throw std::invalid_argument("sigma_t must be finite and >= 0");
  const SphereQuadrature quad(n_theta);
  const int nc = order * order;
  std::vector<float> basis(quad.dirs.size() * nc);
  for (std::size_t k = 0; k < quad.dirs.size(); ++k) sh_eval(order, quad.dirs[k], &basis[k * nc]);

  ShExpTable t;
  t.order = order;
  std::vector<float> norms(count);
  for (std::size_t i = 0; i < count; ++i) {
    double n2 = 0.0;
    for (int c = 1; c < nc; ++c) n2 += std::pow(static_cast<double>(sigma_t) * f[i * nc + c], 2);
    norms[i] = static_cast<float>(std::sqrt(n2));
    t.max_norm = std::max(t.max_norm, norms[i]);
  }
  std::vector<double> t0(bins, 0.0), num(bins, 0.0), den(bins, 0.0);
  std::vector<int> cnt(bins, 0);
  for (std::size_t i = 0; i < count; ++i) {
    float gh[kMaxShOrder * kMaxShOrder];
    gh[0] = 0.0f;
    for (int c = 1; c < nc; ++c) gh[c] = -sigma_t * f[i * nc + c];
    // τ̃ = projection of exp(ĝ·y(ω)): the transmittance over exp(g₀/√4π).
    double tau[kMaxShOrder * kMaxShOrder] = {};
    for (std::size_t k = 0; k < quad.dirs.size(); ++k) {
      double e = 0.0;
      for (int c = 1; c < nc; ++c) e += static_cast<double>(gh[c]) * basis[k * nc + c];
      const double v = std::exp(e) * quad.weights[k];
      for (int c = 0; c < nc; ++c) tau[c] += v * basis[k * nc + c];
    }
    const int bin =
        t.max_norm > 0.0f ? std::min(bins - 1, static_cast<int>(norms[i] / t.max_norm * bins)) : 0;
    t0[bin] += tau[0];
    for (int c = 1; c < nc; ++c) {
      num[bin] += tau[c] * gh[c];
      den[bin] += static_cast<double>(gh[c]) * gh[c];
    }
    ++cnt[bin];
  }
  t.a.assign(bins, 1.0f);
  t.b.assign(bins, 1.0f);
  std::vector<int> filled;
  for (int i = 0; i < bins; ++i) {
    if (cnt[i] == 0) continue;
    filled.push_back(i);
    t.a[i] = static_cast<float>(t0[i] / cnt[i] / kSqrt4Pi);
    // With ĝ = 0 exp(ĝ·y) = 1 and b is free: its small-norm limit (exp ≈ 1 + x) is 1.
    t.b[i] = den[i] > 1e-20 ? static_cast<float>(num[i] / den[i]) : 1.0f;
  }
  for (int i = 0; i < bins; ++i) {
    if (cnt[i] != 0 || filled.empty()) continue;
    int best = filled[0];
    for (int j : filled)
      if (std::abs(j - i) < std::abs(best - i)) best = j;
    t.a[i] = t.a[best];
    t.b[i] = t.b[best];
  }
  return t;
}

std::vector<float> light_volume(const float* f_sun, const float* f_sh, const VolumeGrid& g,
                                const ShExpTable& table, const float* sky_coeffs, float sigma_t,
                                int threads) {
  const int nc = table.order * table.order;
  const std::size_t nv = g.voxels();
  std::vector<float> out(nv * 4);
  parallel_for(nv, threads, [&](std::size_t v) {
    float gv[kMaxShOrder * kMaxShOrder], tau[kMaxShOrder * kMaxShOrder];
    for (int c = 0; c < nc; ++c) gv[c] = -sigma_t * f_sh[v * nc + c];
    table.apply(gv, tau);
    out[v * 4] = std::exp(-sigma_t * f_sun[v]);
    for (int ch = 0; ch < 3; ++ch) {
      double e = 0.0;
      for (int c = 0; c < nc; ++c) e += static_cast<double>(sky_coeffs[ch * nc + c]) * tau[c];
      // Band-limited products can ring slightly below zero; irradiance cannot.
      out[v * 4 + 1 + ch] = static_cast<float>(std::max(0.0, e));
    }
  });
  return out;
}

// --- multiple scattering ---------------------------------------------------------------------

std::vector<glm::vec3> volume_sample_points(const VolumeGrid& g, int count, std::uint64_t seed) {
  g.validate();
  if (count < 1 || count > (1 << 20)) throw std::invalid_argument("ms_points must be in [1, 2^20]");
  int m = 1;
  while (m * m * m < count) ++m;
  const int cells = m * m * m;
  std::vector<int> order(static_cast<std::size_t>(cells));
  for (int i = 0; i < cells; ++i) order[i] = i;
  Rng rng(seed);
  for (int i = cells - 1; i > 0; --i) {  // Fisher–Yates with cumuli's own uniform
    const int j = static_cast<int>(rng.uniform_double() * (i + 1));
    std::swap(order[i], order[std::min(j, i)]);
  }
  std::vector<glm::vec3> pts;
  pts.reserve(static_cast<std::size_t>(count));
  const glm::vec3 cell = (g.box.hi - g.box.lo) / static_cast<float>(m);
  for (int i = 0; i < count; ++i) {
    const int c = order[i];
    const glm::vec3 idx(c % m, (c / m) % m, c / (m * m));
    const glm::vec3 jitter(rng.uniform(), rng.uniform(), rng.uniform());
    pts.push_back(g.box.lo + (idx + jitter) * cell);
  }
  return pts;
}

float optical_depth_segment(const float* vol, const VolumeGrid& g, glm::vec3 a, glm::vec3 b,
                            float step_voxels) {
  const float len = glm::length(b - a);
  if (len <= 0.0f) return 0.0f;
  const glm::vec3 vs = g.voxel_size();
  const float dt = step_voxels * std::min(vs.x, std::min(vs.y, vs.z));
  const int n = std::max(1, static_cast<int>(std::ceil(len / dt)));
  const float h = len / static_cast<float>(n);
  const glm::vec3 dir = (b - a) / len;
  double sum = 0.0;
  for (int i = 0; i < n; ++i) sum += sample_trilinear(vol, g, a + ((i + 0.5f) * h) * dir);
  return static_cast<float>(sum * h);
}

namespace {

// A voxel of a sweep order: its index and coordinates.
struct OrderEntry {
  std::uint32_t v;
  std::uint16_t x, y, z;
};

// The order of the sweep from q: voxels by increasing max-norm distance in voxels, in buckets of
// 1/16 voxel (a counting sort; voxel order within a bucket). A voxel whose neighbours ahead are
// in its own bucket and not swept yet is marched directly, so the order only affects speed.
std::vector<OrderEntry> sweep_order(const VolumeGrid& g, glm::vec3 q) {
  const std::size_t nv = g.voxels();
  const glm::vec3 qi = (q - g.box.lo) / g.voxel_size() - 0.5f;  // q in index coordinates
  constexpr float kPerVoxel = 16.0f;
  std::vector<std::uint32_t> key(nv);
  std::uint32_t top = 0;
  std::size_t v = 0;
  for (int z = 0; z < g.d; ++z)
    for (int y = 0; y < g.h; ++y)
      for (int x = 0; x < g.w; ++x, ++v) {
        const float d = std::max(std::fabs(qi.x - static_cast<float>(x)),
                                 std::max(std::fabs(qi.y - static_cast<float>(y)),
                                          std::fabs(qi.z - static_cast<float>(z))));
        key[v] = static_cast<std::uint32_t>(d * kPerVoxel);
        top = std::max(top, key[v]);
      }
  std::vector<std::uint32_t> start(static_cast<std::size_t>(top) + 2, 0);
  for (std::size_t i = 0; i < nv; ++i) ++start[key[i] + 1];
  for (std::size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
  std::vector<OrderEntry> order(nv);
  v = 0;
  for (int z = 0; z < g.d; ++z)
    for (int y = 0; y < g.h; ++y)
      for (int x = 0; x < g.w; ++x, ++v)
        order[start[key[v]]++] =
            OrderEntry{static_cast<std::uint32_t>(v), static_cast<std::uint16_t>(x),
                       static_cast<std::uint16_t>(y), static_cast<std::uint16_t>(z)};
  return order;
}

// Trilinear density at index coordinates u (voxel centres at integers), clamped to the edges:
// sample_trilinear without the world-to-index division.
inline float trilinear_index(const float* vol, const int n[3], const std::size_t st[3],
                             glm::vec3 u) {
  int i0[3], i1[3];
  float w[3];
  for (int k = 0; k < 3; ++k) {
    const float fl = floor_fast(u[k]);
    w[k] = u[k] - fl;
    const int i = static_cast<int>(fl);
    i0[k] = std::clamp(i, 0, n[k] - 1);
    i1[k] = std::clamp(i + 1, 0, n[k] - 1);
  }
  const auto at = [&](int x, int y, int z) {
    return vol[static_cast<std::size_t>(x) + static_cast<std::size_t>(y) * st[1] +
               static_cast<std::size_t>(z) * st[2]];
  };
  const float c00 =
      at(i0[0], i0[1], i0[2]) + w[0] * (at(i1[0], i0[1], i0[2]) - at(i0[0], i0[1], i0[2]));
  const float c10 =
      at(i0[0], i1[1], i0[2]) + w[0] * (at(i1[0], i1[1], i0[2]) - at(i0[0], i1[1], i0[2]));
  const float c01 =
      at(i0[0], i0[1], i1[2]) + w[0] * (at(i1[0], i0[1], i1[2]) - at(i0[0], i0[1], i1[2]));
  const float c11 =
      at(i0[0], i1[1], i1[2]) + w[0] * (at(i1[0], i1[1], i1[2]) - at(i0[0], i1[1], i1[2]));
  const float c0 = c00 + w[1] * (c10 - c00);
  const float c1 = c01 + w[1] * (c11 - c01);
  return c0 + w[2] * (c1 - c0);
}

// Optical depth from every voxel centre to q by sweeping outwards from q (see DepthMethod): f
// into `f` at stride `stride`; `gm` and `done` are voxels-long scratch. Geometry in index
// coordinates (voxel centres at integers); lengths in world units.
void sweep_point_depth(const float* vol, const VolumeGrid& g, glm::vec3 q, float step_voxels,
                       const std::vector<OrderEntry>& order, float* f, std::size_t stride,
                       float* gm, std::uint8_t* done) {
  const glm::vec3 vs = g.voxel_size();
  const int n[3] = {g.w, g.h, g.d};
  const std::size_t st[3] = {1, static_cast<std::size_t>(g.w),
                             static_cast<std::size_t>(g.w) * static_cast<std::size_t>(g.h)};
  const float dt = step_voxels * min_voxel(g);
  const glm::vec3 qi = (q - g.box.lo) / vs - 0.5f;  // q in index coordinates
  constexpr float kDirect = 2.0f;  // voxels closer than this (max-norm, in voxels) are marched
  // ∫ρ from index point u0 along du (index units) over world length len, n = ⌈len/dt⌉ midpoints.
  const auto segment = [&](glm::vec3 u0, glm::vec3 du, float len) {
    const int m = std::max(1, static_cast<int>(-floor_fast(-len / dt)));  // ⌈len/dt⌉
    const float inv = 1.0f / static_cast<float>(m);
    float sum = 0.0f;
    for (int i = 0; i < m; ++i) sum += trilinear_index(vol, n, st, u0 + ((i + 0.5f) * inv) * du);
    return sum * (len * inv);
  };
  std::fill(done, done + g.voxels(), std::uint8_t{0});
  for (const OrderEntry& o : order) {
    const std::size_t v = o.v;
    const int idx[3] = {o.x, o.y, o.z};
    const glm::vec3 ui(static_cast<float>(idx[0]), static_cast<float>(idx[1]),
                       static_cast<float>(idx[2]));
    const glm::vec3 dqi = qi - ui;             // towards q, index units
    const float dist = glm::length(dqi * vs);  // world units
    const glm::vec3 adq = glm::abs(dqi);
    int a = 0;
    for (int k = 1; k < 3; ++k)
      if (adq[k] > adq[a]) a = k;
    float fv = -1.0f;
    if (adq[a] > kDirect) {
      // x' one slice closer to q along a: the fraction t = 1/|dq_a| of the way.
      const float t = 1.0f / adq[a];
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      const int ka = idx[a] + (dqi[a] > 0.0f ? 1 : -1);
      const float ub = ui[b] + t * dqi[b], uc = ui[c] + t * dqi[c];
      const float fb = floor_fast(ub), fc = floor_fast(uc);
      const float wb = ub - fb, wc = uc - fc;
      const int b0 = std::clamp(static_cast<int>(fb), 0, n[b] - 1);
      const int b1 = std::clamp(static_cast<int>(fb) + 1, 0, n[b] - 1);
      const int c0 = std::clamp(static_cast<int>(fc), 0, n[c] - 1);
      const int c1 = std::clamp(static_cast<int>(fc) + 1, 0, n[c] - 1);
      const std::size_t base = static_cast<std::size_t>(ka) * st[a];
      const std::size_t i00 = base + b0 * st[b] + c0 * st[c], i10 = base + b1 * st[b] + c0 * st[c];
      const std::size_t i01 = base + b0 * st[b] + c1 * st[c], i11 = base + b1 * st[b] + c1 * st[c];
      // Only voxels already swept may be read (those of weight 0 do not matter).
      const bool known = done[i00] && (done[i10] || wb == 0.0f) && (done[i01] || wc == 0.0f) &&
                         (done[i11] || wb == 0.0f || wc == 0.0f);
      if (known) {
        // ∫ρ from x to x' by composite Simpson, panels ≤ 8·step voxels long (trilinear density
        // is a cubic along a line within a cell, which Simpson integrates exactly): ρ(x) is the
        // voxel's own value, ρ(x') the bilinear blend on slice ka with the weights of the depth
        // blend below.
        const float seg_len = t * dist;
        const int panels = std::max(1, static_cast<int>(-floor_fast(-seg_len / (8.0f * dt))));
        const float r00 = vol[i00] + wb * (vol[i10] - vol[i00]);
        const float r01 = vol[i01] + wb * (vol[i11] - vol[i01]);
        const float rho_end = r00 + wc * (r01 - r00);
        float seg;
        if (panels == 1) {
          // The midpoint lies half-way between slices idx[a] and ka: its trilinear value is the
          // mean of the two slices' bilinear values at the same lateral position.
          const float mb = ui[b] + 0.5f * t * dqi[b], mc = ui[c] + 0.5f * t * dqi[c];
          const float gb = floor_fast(mb), gc = floor_fast(mc);
          const float vb = mb - gb, vc = mc - gc;
          const std::size_t m0 =
              static_cast<std::size_t>(std::clamp(static_cast<int>(gb), 0, n[b] - 1)) * st[b];
          const std::size_t m1 =
              static_cast<std::size_t>(std::clamp(static_cast<int>(gb) + 1, 0, n[b] - 1)) * st[b];
          const std::size_t n0 =
              static_cast<std::size_t>(std::clamp(static_cast<int>(gc), 0, n[c] - 1)) * st[c];
          const std::size_t n1 =
              static_cast<std::size_t>(std::clamp(static_cast<int>(gc) + 1, 0, n[c] - 1)) * st[c];
          const auto bilerp = [&](const float* sl) {
            const float p0 = sl[m0 + n0] + vb * (sl[m1 + n0] - sl[m0 + n0]);
            const float p1 = sl[m0 + n1] + vb * (sl[m1 + n1] - sl[m0 + n1]);
            return p0 + vc * (p1 - p0);
          };
          const float near = bilerp(vol + static_cast<std::size_t>(idx[a]) * st[a]);
          const float far = bilerp(vol + base);
          const float mid = near + 0.5f * (far - near);
          seg = (seg_len / 6.0f) * (vol[v] + 4.0f * mid + rho_end);
        } else {
          float odd = 0.0f, even = 0.0f;
          const float inv = 1.0f / static_cast<float>(2 * panels);
          for (int i = 1; i < 2 * panels; i += 2)
            odd += trilinear_index(vol, n, st, ui + (static_cast<float>(i) * inv * t) * dqi);
          for (int i = 2; i < 2 * panels; i += 2)
            even += trilinear_index(vol, n, st, ui + (static_cast<float>(i) * inv * t) * dqi);
          seg = (seg_len * inv / 3.0f) * (vol[v] + 4.0f * odd + 2.0f * even + rho_end);
        }
        const auto val = [&](std::size_t i) { return done[i] ? gm[i] : 0.0f; };
        const float g0 = val(i00) + wb * (val(i10) - val(i00));
        const float g1 = val(i01) + wb * (val(i11) - val(i01));
        fv = seg + (dist - seg_len) * (g0 + wc * (g1 - g0));
      }
    }
    if (fv < 0.0f) fv = dist > 0.0f ? segment(ui, dqi, dist) : 0.0f;
    f[v * stride] = fv;
    gm[v] = dist > 0.0f ? fv / dist : trilinear_index(vol, n, st, qi);
    done[v] = 1;
  }
}

}  // namespace

std::vector<float> point_optical_depth(const float* volumes, int count, const VolumeGrid& g,
                                       const std::vector<glm::vec3>& points, float step_voxels,
                                       int threads, DepthMethod method) {
  g.validate();
  check_step(step_voxels);
  const std::size_t nv = g.voxels(), np = points.size();
  std::vector<float> out(static_cast<std::size_t>(count) * nv * np);
  if (method == DepthMethod::Sweep) {
    // The sweep order of each point depends on the grid only: made once for every volume.
    std::vector<std::vector<OrderEntry>> orders(np);
    parallel_for(np, threads, [&](std::size_t k) { orders[k] = sweep_order(g, points[k]); });
    parallel_chunks(
        static_cast<std::size_t>(count) * np, threads, [&](std::size_t b, std::size_t e) {
          std::vector<float> gm(nv);
          std::vector<std::uint8_t> done(nv);
          for (std::size_t task = b; task < e; ++task) {
            const std::size_t vol = task / np, k = task % np;
            sweep_point_depth(volumes + vol * nv, g, points[k], step_voxels, orders[k],
                              out.data() + vol * nv * np + k, np, gm.data(), done.data());
          }
        });
    return out;
  }
  parallel_for(static_cast<std::size_t>(count) * nv, threads, [&](std::size_t i) {
    const std::size_t v = i % nv;
    const int x = static_cast<int>(v % g.w), y = static_cast<int>((v / g.w) % g.h),
              z = static_cast<int>(v / (static_cast<std::size_t>(g.w) * g.h));
    const glm::vec3 p = g.centre(x, y, z);
    const float* vol = volumes + (i / nv) * nv;
    for (std::size_t k = 0; k < np; ++k)
      out[i * np + k] = optical_depth_segment(vol, g, p, points[k], step_voxels);
  });
  return out;
}

void add_multiple_scattering(const float* density, float* light, const VolumeGrid& g,
                             const float* point_depth, const std::vector<glm::vec3>& points,
                             glm::vec3 sun_radiance, float sigma_t, float albedo, int orders,
                             int threads) {
  g.validate();
  if (orders < 0 || orders > 16) throw std::invalid_argument("ms_orders must be in [0, 16]");
  if (orders == 0 || points.empty()) return;
  const std::size_t nv = g.voxels(), np = points.size();
  const glm::vec3 size = g.box.hi - g.box.lo;
  const double volume = static_cast<double>(size.x) * size.y * size.z;
  const float weight = static_cast<float>(volume / np);
  const float d_min = 0.5f * static_cast<float>(std::cbrt(volume / np));
  const float d2_min = d_min * d_min;
  // E of the previous order at the voxels (RGB), starting with the single scattering.
  std::vector<float> prev(nv * 3), total(nv * 3, 0.0f);
  for (std::size_t v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c)
      prev[v * 3 + c] = sun_radiance[c] * light[v * 4] + light[v * 4 + 1 + c];
  std::vector<glm::vec3> src(np);
  std::vector<float> next(nv * 3);
  for (int n = 0; n < orders; ++n) {
    for (std::size_t k = 0; k < np; ++k) {
      float e[3];
      sample_trilinear(prev.data(), g, 3, points[k], e);
      const float rho = sample_trilinear(density, g, points[k]);
      src[k] =
          (weight * sigma_t * rho * albedo * 0.0795774715459477f) * glm::vec3(e[0], e[1], e[2]);
    }
    parallel_for(nv, threads, [&](std::size_t v) {
      const int x = static_cast<int>(v % g.w), y = static_cast<int>((v / g.w) % g.h),
                z = static_cast<int>(v / (static_cast<std::size_t>(g.w) * g.h));
      const glm::vec3 p = g.centre(x, y, z);
      glm::dvec3 acc(0.0);
      for (std::size_t k = 0; k < np; ++k) {
        const glm::vec3 d = points[k] - p;
        const float g2 = std::max(glm::dot(d, d), d2_min);
        acc += glm::dvec3(src[k] * (std::exp(-sigma_t * point_depth[v * np + k]) / g2));
      }
      for (int c = 0; c < 3; ++c) next[v * 3 + c] = static_cast<float>(acc[c]);
    });
    for (std::size_t i = 0; i < nv * 3; ++i) total[i] += next[i];
    prev.swap(next);
  }
  for (std::size_t v = 0; v < nv; ++v)
    for (int c = 0; c < 3; ++c) light[v * 4 + 1 + c] += total[v * 3 + c];
}

}  // namespace cumuli
