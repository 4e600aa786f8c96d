#include "cumuli/light/physical.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

#include <glm/geometric.hpp>

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__)
#include <immintrin.h>
#define CUMULI_X86_SKY 1
#endif

#include "cumuli/candidates.hpp"
#include "cumuli/light/cell_system.hpp"
#include "cumuli/parallel.hpp"
#include "cumuli/simd.hpp"

namespace cumuli {

namespace {

constexpr int kMaxCandidates = 256;
// The sky's march stops once τ > kSkyDepthCut: the visibility left, e^−6 ≈ 0.25 %, is dropped.
constexpr double kSkyDepthCut = 6.0;

// A ray's samples through one cloud, gathered before their density is known (one buffer per
// thread, reused from ray to ray): each sample's ray parameter s, length, marched candidate and
// point (x, y, z), the smallest |q|² of the candidates that cover it, and where it can hold
// density (inside its owner primitive, or the metaball iso-surface), its point, |q| and fBm.
// Sized, not pushed to: `count` samples, `dense_count` dense ones.
struct MarchSamples {
  std::vector<float> s, len, x, y, z, q2;
  std::vector<int> marched;
  std::vector<int> dense;  // index of the sample's point in pts / q / fbm, or −1 (no density)
  std::vector<float> pts, q, fbm;
  std::vector<Candidate> candidates = std::vector<Candidate>(kMaxCandidates);
  std::size_t count = 0, dense_count = 0;
  void reserve(std::size_t n) {
    if (s.size() >= n) return;
    for (auto* v : {&s, &len, &x, &y, &z, &q2, &q, &fbm}) v->resize(n);
    marched.resize(n);
    dense.resize(n);
    pts.resize(3 * n);
  }
};

// The calling thread's buffer (taken once per march: each access to a thread_local in a shared
// library can cost a call). Not inlined: inlined, the compiler may take the address again (that
// call) wherever it runs out of registers to keep it in.
#if defined(__GNUC__)
#define CUMULI_OPAQUE __attribute__((noinline))
#else
#define CUMULI_OPAQUE
#endif
CUMULI_OPAQUE MarchSamples& march_samples() {
  thread_local MarchSamples m;
  return m;
}

// light_space_depth's per-column buffers: the segments of a column and the primitives it meets.
struct ColumnBuffers {
  std::vector<std::array<float, 3>> segs;
  std::vector<int> subset;
};

CUMULI_OPAQUE ColumnBuffers& column_buffers() {
  thread_local ColumnBuffers b;
  return b;
}

// Calls visit(s, σt, ℓ) for the segments of o + t·d, t in [t0, t1], inside the union of the
// cloud's candidate intervals: segments of at most `step` from each union interval's start (the
// last one cut at its end), σt at the midpoint s with the union attribution rule. The samples
// are laid out first and the fBm of those that can hold density evaluated in bulk calls (the
// SIMD kernels): the same values as one cloud_density per sample, visited in order.
//
// With a finite `stop_depth` the samples are laid out and evaluated a chunk at a time and the
// march ends after the segment where the optical depth visited so far exceeds it: the segments
// visited are the first ones of the unstopped march, bit for bit.
template <class Visit>
void march_cloud(const CloudMedium& c, glm::vec3 o, glm::vec3 d, float t0, float t1, float step,
                 Visit&& visit, const std::vector<int>* subset = nullptr,
                 double stop_depth = INFINITY) {
  MarchSamples& m = march_samples();
  // The thread's buffer, not a local array: that would be initialised on every call (its
  // Candidates have default values), a cost as large as a short column's march.
  Candidate* cand = m.candidates.data();
  const CloudShape& shape = *c.shape;
  const int n = subset == nullptr
                    ? collect_candidates(shape, o, d, t0, t1, cand, kMaxCandidates, true)
                    : collect_candidates(shape, subset->data(), static_cast<int>(subset->size()), o,
                                         d, t0, t1, cand, kMaxCandidates, true);
  if (n == 0) return;
  const bool attribute = shape.density.model == DensityModel::Spheroid;
  bool unrotated[kMaxCandidates];
  for (int j = 0; j < n; ++j)
    unrotated[j] = shape.primitives[static_cast<std::size_t>(cand[j].primitive)].unrotated();
  const bool stops = std::isfinite(stop_depth);
  constexpr std::size_t kStopChunk = 64;  // samples laid out between checks of the depth
  m.reserve(kStopChunk);
  // Where the layout stands: candidate k, ray parameter t, and whether t lies in k's interval.
  int k = 0;
  float t = -INFINITY;
  bool in_interval = false;
  // Lays out the next samples' s, length and marched candidate (all of them, or kStopChunk when
  // the march may stop); false once the ray's candidates are done. s only grows along the march.
  const auto lay_out = [&]() {
    m.count = 0;
    for (; k < n; ++k) {
      if (!in_interval) {
        if (cand[k].t_out <= t) continue;
        t = std::max(t, cand[k].t_in);
        in_interval = true;
      }
      while (t < cand[k].t_out) {
        if (stops && m.count == kStopChunk) return true;
        if (m.count == m.s.size()) m.reserve(2 * m.count);
        const float end = std::min(t + step, cand[k].t_out);
        m.s[m.count] = 0.5f * (t + end);
        m.len[m.count] = end - t;
        m.marched[m.count] = k;
        ++m.count;
        t = end;
      }
      in_interval = false;
    }
    return false;
  };
  // union_owner's rule for the laid-out samples: the owner of s is the covering candidate
  // (t_in ≤ s ≤ t_out) with the smallest |q|, and its |q| is the one eq. (2) needs. Taken a
  // candidate at a time over the samples it covers (a run of them: s is sorted), min_q2 gives
  // every sample its smallest |q|² in loops that vectorise, each lane rounding as one owner per
  // sample would. A sample that rounding left outside every interval takes its marched
  // candidate's |q|.
  const auto smallest_q2 = [&]() {
    const std::size_t count = m.count;
    const float* s = m.s.data();
    float *x = m.x.data(), *y = m.y.data(), *z = m.z.data(), *q2 = m.q2.data();
    for (std::size_t i = 0; i < count; ++i) {  // p = o + s·d, as glm forms it
      x[i] = o.x + s[i] * d.x;
      y[i] = o.y + s[i] * d.y;
      z[i] = o.z + s[i] * d.z;
    }
    std::fill(q2, q2 + count, INFINITY);
    const auto take = [&](int j, std::size_t i0, std::size_t i1) {
      min_q2(shape.primitives[static_cast<std::size_t>(cand[j].primitive)], unrotated[j], x + i0,
             y + i0, z + i0, i1 - i0, q2 + i0);
    };
    const float s_first = s[0], s_last = s[count - 1];
    for (int j = 0; j < n && cand[j].t_in <= s_last; ++j) {
      if (cand[j].t_out < s_first) continue;
      take(j, static_cast<std::size_t>(std::lower_bound(s, s + count, cand[j].t_in) - s),
           static_cast<std::size_t>(std::upper_bound(s, s + count, cand[j].t_out) - s));
    }
    for (std::size_t i = 0; i < count; ++i)
      if (q2[i] == INFINITY) take(m.marched[i], i, i + 1);
  };
  // Which samples can hold density, and their points: written at the next dense slot whether
  // dense or not (branch-free: the edge samples' tests are unpredictable).
  const auto gather_dense = [&]() {
    std::size_t g = 0;
    if (attribute) {
      smallest_q2();
      for (std::size_t i = 0; i < m.count; ++i) {
        const float q = std::sqrt(m.q2[i]);  // sqrt is monotonic: the root of the smallest |q|²
        const bool dense = q <= 1.0f;
        m.q[g] = q;
        m.pts[3 * g] = m.x[i];
        m.pts[3 * g + 1] = m.y[i];
        m.pts[3 * g + 2] = m.z[i];
        m.dense[i] = dense ? static_cast<int>(g) : -1;
        g += dense ? 1 : 0;
      }
    } else {
      for (std::size_t i = 0; i < m.count; ++i) {
        const glm::vec3 p = o + m.s[i] * d;
        const bool dense = metaball_inside(shape, p);
        m.dense[i] = dense ? static_cast<int>(g) : -1;
        if (dense) {
          m.pts[3 * g] = p.x;
          m.pts[3 * g + 1] = p.y;
          m.pts[3 * g + 2] = p.z;
          ++g;
        }
      }
    }
    m.dense_count = g;
  };
  const float kappa = shape.density.kappa;
  double tau = 0.0;
  bool more = true;
  while (more) {
    more = lay_out();
    if (m.count == 0) break;
    gather_dense();
    c.source.many(noise_points(shape, m.pts.data(), m.dense_count), m.dense_count, m.fbm.data());
    for (std::size_t i = 0; i < m.count; ++i) {
      const int g = m.dense[i];
      float rho = 0.0f;
      if (g >= 0) {
        const std::size_t gi = static_cast<std::size_t>(g);
        rho = attribute ? spheroid_density_given(kappa, m.q[gi], m.fbm[gi]).rho
                        : metaball_rho(shape, m.fbm[gi]);
      }
      const float sigma = c.scale * rho;
      visit(m.s[i], sigma, m.len[i]);
      if (stops) {
        tau += static_cast<double>(sigma) * m.len[i];
        if (tau > stop_depth) return;
      }
    }
  }
}

// As march_cloud, for a volume's trilinear lattice: segments of equal length across its box.
template <class Visit>
void march_volume(const VolumeMedium& v, glm::vec3 o, glm::vec3 d, float t0, float t1, float step,
                  Visit&& visit, double stop_depth = INFINITY) {
  Interval span;
  if (!intersect(v.grid.box, o, 1.0f / d, span)) return;
  const float a = std::max(span.t_in, t0), b = std::min(span.t_out, t1);
  if (!(b > a)) return;
  const int n = std::max(1, static_cast<int>(std::ceil((b - a) / step)));
  const float h = (b - a) / static_cast<float>(n);
  double tau = 0.0;
  for (int i = 0; i < n; ++i) {
    const float s = a + (static_cast<float>(i) + 0.5f) * h;
    const float sigma = v.scale * sample_trilinear(v.density, v.grid, o + s * d);
    visit(s, sigma, h);
    tau += static_cast<double>(sigma) * h;
    if (tau > stop_depth) return;
  }
}

void split(float u, int n, int& i0, int& i1, float& f) {
  const float s = u - 0.5f;
  const float fl = std::floor(s);
  f = s - fl;
  i0 = std::clamp(static_cast<int>(fl), 0, n - 1);
  i1 = std::clamp(static_cast<int>(fl) + 1, 0, n - 1);
}

// Fixed blocks for reductions: sums do not depend on the thread count.
constexpr std::size_t kBlock = 4096;

// Trilinear value of a single-channel [z][y][x] lattice at voxel coordinates u (texel centres at
// integer + ½, clamped to the edges): sample_trilinear without the world-to-voxel division.
inline float trilinear_voxel(const float* vol, int w, int h, int d, glm::vec3 u) {
  const float sx = u.x - 0.5f, sy = u.y - 0.5f, sz = u.z - 0.5f;
  const float flx = std::floor(sx), fly = std::floor(sy), flz = std::floor(sz);
  const float fx = sx - flx, fy = sy - fly, fz = sz - flz;
  const int ix = static_cast<int>(flx), iy = static_cast<int>(fly), iz = static_cast<int>(flz);
  const int x0 = std::clamp(ix, 0, w - 1), x1 = std::clamp(ix + 1, 0, w - 1);
  const int y0 = std::clamp(iy, 0, h - 1), y1 = std::clamp(iy + 1, 0, h - 1);
  const int z0 = std::clamp(iz, 0, d - 1), z1 = std::clamp(iz + 1, 0, d - 1);
  const std::size_t W = static_cast<std::size_t>(w), WH = W * static_cast<std::size_t>(h);
  const float* a = vol + z0 * WH;
  const float* b = vol + z1 * WH;
  const std::size_t r0 = y0 * W, r1 = y1 * W;
  const float c00 = a[r0 + x0] + fx * (a[r0 + x1] - a[r0 + x0]);
  const float c10 = a[r1 + x0] + fx * (a[r1 + x1] - a[r1 + x0]);
  const float c01 = b[r0 + x0] + fx * (b[r0 + x1] - b[r0 + x0]);
  const float c11 = b[r1 + x0] + fx * (b[r1 + x1] - b[r1 + x0]);
  const float c0 = c00 + fy * (c10 - c00);
  const float c1 = c01 + fy * (c11 - c01);
  return c0 + fz * (c1 - c0);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The sun's frame

glm::vec3 SunFrame::to_frame(glm::vec3 p) const {
  return glm::vec3(glm::dot(p, u), glm::dot(p, v), glm::dot(p, w));
}

glm::vec3 SunFrame::node(int i, int j, int k) const {
  const glm::vec3 f =
      lo + (glm::vec3(static_cast<float>(i), static_cast<float>(j), static_cast<float>(k)) + 0.5f) *
               (hi - lo) /
               glm::vec3(static_cast<float>(res[0]), static_cast<float>(res[1]),
                         static_cast<float>(res[2]));
  return f.x * u + f.y * v + f.z * w;
}

void SunFrame::validate() const {
  for (int a = 0; a < 3; ++a) {
    if (res[a] < 2 || res[a] > 4096)
      throw std::invalid_argument("light frame resolution must be in [2, 4096]");
    if (!(hi[a] > lo[a]) || !std::isfinite(lo[a]) || !std::isfinite(hi[a]))
      throw std::invalid_argument("light frame box must be finite and non-empty");
  }
}

SunFrame make_sun_frame(const Box& world_box, glm::vec3 to_sun, const int res[3]) {
  const float len = glm::length(to_sun);
  if (!(len > 0.0f) || !std::isfinite(len))
    throw std::invalid_argument("sun direction must be non-zero");
  SunFrame f;
  f.w = -to_sun / len;
  const glm::vec3 a =
      std::abs(f.w.y) < 0.9f ? glm::vec3(0.0f, 1.0f, 0.0f) : glm::vec3(1.0f, 0.0f, 0.0f);
  f.u = glm::normalize(glm::cross(a, f.w));
  f.v = glm::cross(f.w, f.u);
  glm::vec3 lo(INFINITY), hi(-INFINITY);
  for (int c = 0; c < 8; ++c) {
    const glm::vec3 p((c & 1) ? world_box.hi.x : world_box.lo.x,
                      (c & 2) ? world_box.hi.y : world_box.lo.y,
                      (c & 4) ? world_box.hi.z : world_box.lo.z);
    const glm::vec3 q = f.to_frame(p);
    lo = glm::min(lo, q);
    hi = glm::max(hi, q);
  }
  for (int k = 0; k < 3; ++k) {
    f.res[k] = res[k];
    const float pad = 0.5f * (hi[k] - lo[k]) / static_cast<float>(std::max(res[k] - 1, 1));
    f.lo[k] = lo[k] - pad;
    f.hi[k] = hi[k] + pad;
  }
  f.validate();
  return f;
}

float sample_frame(const float* values, const SunFrame& f, glm::vec3 p, const float* columns) {
  const glm::vec3 q = (f.to_frame(p) - f.lo) / (f.hi - f.lo) *
                      glm::vec3(static_cast<float>(f.res[0]), static_cast<float>(f.res[1]),
                                static_cast<float>(f.res[2]));
  int x0, x1, y0, y1, z0, z1;
  float fx, fy, fz;
  split(q.x, f.res[0], x0, x1, fx);
  split(q.y, f.res[1], y0, y1, fy);
  split(q.z, f.res[2], z0, z1, fz);
  const std::size_t nu = static_cast<std::size_t>(f.res[0]),
                    nv = static_cast<std::size_t>(f.res[1]);
  auto at = [&](int x, int y, int z) { return values[(z * nv + y) * nu + x]; };
  const float c00 = at(x0, y0, z0) + fx * (at(x1, y0, z0) - at(x0, y0, z0));
  const float c10 = at(x0, y1, z0) + fx * (at(x1, y1, z0) - at(x0, y1, z0));
  const float c01 = at(x0, y0, z1) + fx * (at(x1, y0, z1) - at(x0, y0, z1));
  const float c11 = at(x0, y1, z1) + fx * (at(x1, y1, z1) - at(x0, y1, z1));
  const float c0 = c00 + fy * (c10 - c00);
  const float c1 = c01 + fy * (c11 - c01);
  const float value = c0 + fz * (c1 - c0);
  if (columns == nullptr) return value;
  // The same (u, v) corners and fractions, without z: the per-column map's bilinear value.
  auto col = [&](int x, int y) { return columns[y * nu + x]; };
  const float b0 = col(x0, y0) + fx * (col(x1, y0) - col(x0, y0));
  const float b1 = col(x0, y1) + fx * (col(x1, y1) - col(x0, y1));
  return value + (b0 + fy * (b1 - b0));
}

double carried_factor(double tau, double k, const CarriedSource& carried) {
  const double direct = std::exp(-k * tau);
  const double m = carried.share, a = carried.rate;
  if (m <= 0.0) return direct;
  // a/(a − k)·(e^{−kτ} − e^{−aτ}) = a·e^{−kτ}·(1 − e^{−(a−k)τ})/(a − k), → a·τ·e^{−kτ} as a → k.
  const double x = (a - k) * tau;
  const double spread = std::abs(x) < 1e-8 ? tau : -std::expm1(-x) / (a - k);
  return (1.0 - m) * direct + m * a * direct * spread;
}

LargeVector<float> lattice_transmittance(const float* depth, const SunFrame& f, glm::vec3 lo,
                                         glm::vec3 cell, const int dims[3], int threads,
                                         const float* columns, float depth_scale,
                                         const CarriedSource& carried) {
  f.validate();
  const std::size_t w = static_cast<std::size_t>(dims[0]), h = static_cast<std::size_t>(dims[1]),
                    d = static_cast<std::size_t>(dims[2]);
  LargeVector<float> out(w * h * d);
  parallel_for(d * h, threads, [&](std::size_t row) {
    const float y = lo.y + (static_cast<float>(row % h) + 0.5f) * cell.y;
    const float z = lo.z + (static_cast<float>(row / h) + 0.5f) * cell.z;
    for (std::size_t i = 0; i < w; ++i) {
      const float x = lo.x + (static_cast<float>(i) + 0.5f) * cell.x;
      const float tau = sample_frame(depth, f, glm::vec3(x, y, z), columns);
      out[row * w + i] = carried.share > 0.0f
                             ? static_cast<float>(carried_factor(tau, depth_scale, carried))
                             : std::exp(-(depth_scale * tau));  // 1·τ is τ exactly
    }
  });
  return out;
}

// ---------------------------------------------------------------------------------------------
// Optical depths

float Medium::optical_depth(glm::vec3 o, glm::vec3 d, float step) const {
  double tau = 0.0;
  auto add = [&](float, float sigma, float len) { tau += static_cast<double>(sigma) * len; };
  for (const CloudMedium& c : clouds) {
    Interval span;
    const Box box = candidate_bounds(*c.shape);
    if (!intersect(box, o, 1.0f / d, span) || span.t_out <= 0.0f) continue;
    march_cloud(c, o, d, std::max(span.t_in, 0.0f), span.t_out, step, add);
  }
  for (const VolumeMedium& v : volumes) march_volume(v, o, d, 0.0f, INFINITY, step, add);
  return static_cast<float>(tau);
}

LargeVector<float> light_space_depth(const Medium& medium, const SunFrame& f, float step,
                                     int threads, double depth_cut) {
  f.validate();
  if (!(step > 0.0f) || !std::isfinite(step)) throw std::invalid_argument("step must be > 0");
  if (!(depth_cut > 0.0)) throw std::invalid_argument("depth_cut must be > 0");
  const std::size_t nu = static_cast<std::size_t>(f.res[0]),
                    nv = static_cast<std::size_t>(f.res[1]),
                    nw = static_cast<std::size_t>(f.res[2]);
  LargeVector<float> out(nu * nv * nw, 0.0f);
  const float dw = (f.hi.z - f.lo.z) / static_cast<float>(nw);
  const float length = f.hi.z - f.lo.z;
  // Every column runs along w: it can meet a primitive only where its (u, v) frame coordinates
  // lie within the primitive's extent across the light (its support c·a ± |diag(r)·Rᵀa|, with
  // the radii grown by candidate_scale, padded well beyond rounding). Each column tests only
  // those primitives: the same candidates as testing all of them.
  std::vector<std::vector<std::array<float, 4>>> across(medium.clouds.size());
  for (std::size_t m = 0; m < medium.clouds.size(); ++m) {
    const CloudShape& shape = *medium.clouds[m].shape;
    const float scale = candidate_scale(shape);
    for (const Ellipsoid& e : shape.primitives) {
      std::array<float, 4> r{};
      const glm::vec3 axes[2] = {f.u, f.v};
      for (int a = 0; a < 2; ++a) {
        const glm::vec3 local = glm::transpose(e.rotation) * axes[a] * (e.radii * scale);
        const float half = glm::length(local), mid = glm::dot(e.centre, axes[a]);
        const float pad = 1e-3f * half + 1e-4f * (1.0f + std::abs(mid) + length);
        r[2 * a] = mid - half - pad;
        r[2 * a + 1] = mid + half + pad;
      }
      across[m].push_back(r);
    }
  }
  parallel_for(nu * nv, threads, [&](std::size_t col) {
    const int i = static_cast<int>(col % nu), j = static_cast<int>(col / nu);
    const glm::vec3 n0 = f.node(i, j, 0);
    const glm::vec3 origin = n0 - (0.5f * dw) * f.w;  // on the sun-side face
    // Segments of every drawable, merged in order of t (drawables may overlap); the buffers are
    // the thread's, reused from column to column, and taken once per column (each access to a
    // thread_local in a shared library can cost a call, and `keep` runs once per segment).
    ColumnBuffers& buffers = column_buffers();
    std::vector<std::array<float, 3>>& segs = buffers.segs;
    std::vector<int>& subset = buffers.subset;
    segs.clear();
    auto keep = [&](float s, float sigma, float len) {
      if (sigma > 0.0f) segs.push_back({s - 0.5f * len, s + 0.5f * len, sigma});
    };
    const float ou = glm::dot(origin, f.u), ov = glm::dot(origin, f.v);
    for (std::size_t m = 0; m < medium.clouds.size(); ++m) {
      subset.clear();
      for (std::size_t k = 0; k < across[m].size(); ++k) {
        const std::array<float, 4>& r = across[m][k];
        if (ou >= r[0] && ou <= r[1] && ov >= r[2] && ov <= r[3])
          subset.push_back(static_cast<int>(k));
      }
      if (!subset.empty())
        march_cloud(medium.clouds[m], origin, f.w, 0.0f, length, step, keep, &subset, depth_cut);
    }
    for (const VolumeMedium& v : medium.volumes)
      march_volume(v, origin, f.w, 0.0f, length, step, keep, depth_cut);
    if (segs.empty()) return;
    // τ(t) = Σ over segments of σ·|[a, b] ∩ [0, t]|, at the nodes t_k = (k + ½)·dw.
    auto earlier = [](const auto& a, const auto& b) { return a[0] < b[0]; };
    if (!std::is_sorted(segs.begin(), segs.end(), earlier))  // one drawable's come in order
      std::sort(segs.begin(), segs.end(), earlier);
    double done = 0.0;  // τ of the segments wholly before the current node
    std::size_t next = 0;
    for (std::size_t k = 0; k < nw; ++k) {
      const float t = (static_cast<float>(k) + 0.5f) * dw;
      while (next < segs.size() && segs[next][1] <= t) {
        done += static_cast<double>(segs[next][2]) * (segs[next][1] - segs[next][0]);
        ++next;
      }
      double partial = 0.0;
      for (std::size_t m = next; m < segs.size() && segs[m][0] < t; ++m)
        partial += static_cast<double>(segs[m][2]) * (t - segs[m][0]);
      out[(k * nv + static_cast<std::size_t>(j)) * nu + static_cast<std::size_t>(i)] =
          static_cast<float>(done + partial);
    }
  });
  return out;
}

namespace {

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__GLIBC__)
#define SKY_VEC_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define SKY_VEC_CLONES
#endif

// The 26 steps to a voxel's neighbours (faces, edges, corners): on a lattice of cubic voxels their
// directions are the nodes of Lebedev's 26-point rule on the sphere (exact for spherical
// polynomials of degree ≤ 7), with weights 4π·{1/21, 4/105, 9/280} by the number of axes moved.
struct LatticeDirection {
  glm::ivec3 step;
  float weight;
};

std::vector<LatticeDirection> lattice_directions() {
  constexpr double kFourPi = 12.566370614359172;
  const double weight[4] = {0.0, kFourPi / 21.0, kFourPi * 4.0 / 105.0, kFourPi * 9.0 / 280.0};
  std::vector<LatticeDirection> out;
  for (int z = -1; z <= 1; ++z)
    for (int y = -1; y <= 1; ++y)
      for (int x = -1; x <= 1; ++x) {
        const int moved = (x != 0) + (y != 0) + (z != 0);
        if (moved > 0) out.push_back({{x, y, z}, static_cast<float>(weight[moved])});
      }
  return out;
}

// τ at every voxel centre along the lattice step D (each component −1, 0 or 1) to the box: the
// recurrence τ(x) = ∫ from x to x + D + τ(x + D), voxels visited so that x + D comes first.
// Along one step the trilinear field is a polynomial of degree ≤ 3 (the number of axes moved),
// so Simpson's rule on its end values and midpoint (the mean of the 2, 4 or 8 voxels around
// it) is exact; a voxel whose step leaves the lattice integrates the edge-clamped field over the
// half voxel to the box face the same way. Exact for the trilinear field, as a march with
// vanishing steps would be.
// tau[v] = sixth·(ρ(v) + 4·mean of the N voxels around the step's midpoint + ρ(v + dv)) + tau[v +
// dv] for v in [vb, ve) of one row, whose steps land in another row already done (so the voxels are
// independent and the loop vectorises).
template <int N>
SKY_VEC_CLONES void lattice_row(float* tau, const float* ext, std::ptrdiff_t vb, std::ptrdiff_t ve,
                                const std::ptrdiff_t* around, std::ptrdiff_t dv, float sixth) {
  constexpr float inv = 1.0f / static_cast<float>(N);
#pragma GCC ivdep
  for (std::ptrdiff_t v = vb; v < ve; ++v) {
    float mid = 0.0f;
    for (int k = 0; k < N; ++k) mid += ext[v + around[k]];
    tau[v] = sixth * (ext[v] + 4.0f * (mid * inv) + ext[v + dv]) + tau[v + dv];
  }
}

void lattice_optical_depth(const float* ext, const VolumeGrid& g, glm::ivec3 D, float* tau) {
  const glm::vec3 vs = g.voxel_size();
  const float len = glm::length(glm::vec3(D) * vs);  // world length of one step
  const float sixth = len / 6.0f;
  const std::ptrdiff_t sy = g.w, sz = static_cast<std::ptrdiff_t>(g.w) * g.h;
  const std::ptrdiff_t dv = D.x + D.y * sy + D.z * sz;
  // The voxels around the step's midpoint: x + any subset of D's axes (x and x + D among them).
  std::array<std::ptrdiff_t, 8> around{};
  int count = 0;
  for (int bz = 0; bz <= (D.z != 0); ++bz)
    for (int by = 0; by <= (D.y != 0); ++by)
      for (int bx = 0; bx <= (D.x != 0); ++bx)
        around[count++] = bx * D.x + by * D.y * sy + bz * D.z * sz;
  // Half a step to the box face, through the edge-clamped field.
  const auto to_face = [&](int x, int y, int z) {
    const glm::vec3 u = glm::vec3(x, y, z) + 0.5f, d(D);
    const float a = ext[x + y * sy + z * sz];
    const float q = trilinear_voxel(ext, g.w, g.h, g.d, u + 0.25f * d);
    const float e = trilinear_voxel(ext, g.w, g.h, g.d, u + 0.5f * d);
    return 0.5f * sixth * (a + 4.0f * q + e);
  };
  // Rows in lexicographic order against the step, so that x + D is always done before x. Only a
  // row's first or last voxel can step out across x; the others step into another row (done
  // already) unless the step runs along x alone.
  const auto start = [](int c, int n) { return c > 0 ? n - 1 : 0; };
  const auto inc = [](int c) { return c > 0 ? -1 : 1; };
  const int xa = D.x < 0 ? 1 : 0, xb = D.x > 0 ? g.w - 1 : g.w;  // x whose step stays inside
  for (int kz = 0, z = start(D.z, g.d); kz < g.d; ++kz, z += inc(D.z)) {
    const bool z_in = z + D.z >= 0 && z + D.z < g.d;
    for (int ky = 0, y = start(D.y, g.h); ky < g.h; ++ky, y += inc(D.y)) {
      const std::ptrdiff_t row = y * sy + z * sz;
      if (!(z_in && y + D.y >= 0 && y + D.y < g.h)) {
        for (int x = 0; x < g.w; ++x) tau[row + x] = to_face(x, y, z);
        continue;
      }
      if (D.x != 0) tau[row + (D.x > 0 ? g.w - 1 : 0)] = to_face(D.x > 0 ? g.w - 1 : 0, y, z);
      if (D.y == 0 && D.z == 0) {  // along x: each voxel needs the one before it
        for (int k = 0, x = D.x > 0 ? g.w - 2 : 1; k < g.w - 1; ++k, x -= D.x) {
          const std::ptrdiff_t v = row + x;
          tau[v] =
              sixth * (ext[v] + 4.0f * (0.5f * (ext[v] + ext[v + dv])) + ext[v + dv]) + tau[v + dv];
        }
        continue;
      }
      const std::ptrdiff_t vb = row + xa, ve = row + xb;
      if (count == 2)
        lattice_row<2>(tau, ext, vb, ve, around.data(), dv, sixth);
      else if (count == 4)
        lattice_row<4>(tau, ext, vb, ve, around.data(), dv, sixth);
      else
        lattice_row<8>(tau, ext, vb, ve, around.data(), dv, sixth);
    }
  }
}

// e^{−x} for x ≥ 0 in plain float operations, so that a loop of it vectorises (std::exp does
// not) and gives the same bits on every instruction set: x = n·ln 2 − r with n the nearest
// integer, e^{−r} by a degree-7 polynomial on |r| ≤ ln 2 / 2 (Cephes' expf coefficients,
// relative error ~2e−7), times 2^−n built in the exponent bits. Below e^−87 it returns e^−87.
inline float exp_neg(float x) {
  x = std::min(std::max(x, 0.0f), 87.0f);
  const int n = static_cast<int>(x * 1.44269504088896341f + 0.5f);
  const float fn = static_cast<float>(n);
  const float r = (fn * 0.693359375f - x) + fn * -2.12194440e-4f;  // −x + n·ln 2, split ln 2
  float p = 1.9875691500e-4f;
  p = p * r + 1.3981999507e-3f;
  p = p * r + 8.3334519073e-3f;
  p = p * r + 4.1665795894e-2f;
  p = p * r + 1.6666665459e-1f;
  p = p * r + 5.0000001201e-1f;
  p = p * (r * r) + r + 1.0f;
  const std::uint32_t bits = static_cast<std::uint32_t>(127 - n) << 23;
  float scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return p * scale;
}

// acc[c][v] += e^{−τ[v]}·wy[c] for voxels [vb, ve): one direction's share of the visibility's
// SH moments (wy its quadrature weight × its basis values), coefficient-major so the voxel loop
// vectorises. Compiled for the baseline and AVX2 / AVX-512 (the same operations, so the same bits).
SKY_VEC_CLONES void add_visibility(float* acc, std::size_t nv, const float* tau, std::size_t vb,
                                   std::size_t ve, const float* wy, int nc, float* scratch) {
  for (std::size_t v = vb; v < ve; ++v) scratch[v - vb] = exp_neg(tau[v]);
  for (int c = 0; c < nc; ++c) {
    float* a = acc + static_cast<std::size_t>(c) * nv;
    const float w = wy[c];
    for (std::size_t v = vb; v < ve; ++v) a[v] += scratch[v - vb] * w;
  }
}

// The sky march takes a run of kSkyLanes neighbouring voxels along x, one per SIMD lane, and
// marches them along one direction together. Their rays are the same ray moved by whole voxels:
// sample i of every lane lies at (i + ½)·du voxels from its voxel's centre, so all lanes share
// the sample's fractional position, and their trilinear corners are kSkyLanes consecutive
// lattice values — plain vector loads, no gathers. A ray runs in steps of dt to where it leaves
// the box; its last sample, at the same spacing, weighs only the part of its step inside the box.
constexpr int kSkyLanes = 16;

// A lattice copied with a border of `pad` voxels that repeat its edge (clamp-to-edge reads need no
// clamping), and kSlack spare values before and after it: a run's lanes that lie past the
// lattice's end read there (their samples are never counted).
struct PaddedLattice {
  static constexpr std::size_t kSlack = 2 * kSkyLanes;
  LargeVector<float> v;
  int pad, w, h, d;  // border and padded dimensions
  PaddedLattice(const float* ext, const VolumeGrid& g, int border)
      : pad(border), w(g.w + 2 * border), h(g.h + 2 * border), d(g.d + 2 * border) {
    v.assign(static_cast<std::size_t>(w) * h * d + 2 * kSlack, 0.0f);
    float* out = v.data() + kSlack;
    for (int z = 0; z < d; ++z)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const int sx = std::clamp(x - pad, 0, g.w - 1), sy = std::clamp(y - pad, 0, g.h - 1),
                    sz = std::clamp(z - pad, 0, g.d - 1);
          out[(static_cast<std::size_t>(z) * h + y) * w + x] =
              ext[(static_cast<std::size_t>(sz) * g.h + sy) * g.w + sx];
        }
  }
  const float* origin() const { return v.data() + kSlack; }  // the padded lattice's first value
  // Padded index of lattice voxel (x, y, z).
  std::ptrdiff_t index(int x, int y, int z) const {
    return (static_cast<std::ptrdiff_t>(z + pad) * h + (y + pad)) * w + (x + pad);
  }
};

// One direction's rays for a run of kSkyLanes voxels starting at lattice voxel (x0, y, z): steps
// du (voxel units) of length dt; lane l takes n[l] samples, the last weighing last[l] (≤ dt).
// Lanes with no ray (past the row, or no medium near) have n = 0.
struct SkyRun {
  std::ptrdiff_t first;  // padded index of the run's first voxel
  glm::vec3 du;
  float dt;
  float last[kSkyLanes];
  int n[kSkyLanes];
};

// Sample i's shared offset from the lanes' voxels: the lattice step to its trilinear cell's
// first corner (padded index units) and the fractions within the cell.
struct SkySample {
  std::ptrdiff_t offset;
  float fx, fy, fz;
};
inline SkySample sky_sample(const SkyRun& r, int i, int w, int wh) {
  const float k = static_cast<float>(i) + 0.5f;
  // Voxel coordinates minus ½ (trilinear's texel centres) of sample i, less the voxel's index.
  const float sx = k * r.du.x, sy = k * r.du.y, sz = k * r.du.z;
  const float flx = std::floor(sx), fly = std::floor(sy), flz = std::floor(sz);
  return {static_cast<std::ptrdiff_t>(flz) * wh + static_cast<std::ptrdiff_t>(fly) * w +
              static_cast<std::ptrdiff_t>(flx),
          sx - flx, sy - fly, sz - flz};
}

// A lane's weight at sample i: dt on its ray, its last weight at its last sample, 0 after.
inline float sky_weight(const SkyRun& r, int l, int i) {
  return i < r.n[l] - 1 ? r.dt : (i == r.n[l] - 1 ? r.last[l] : 0.0f);
}

// τ along each lane's ray, summed sample by sample in double while it is ≤ kSkyDepthCut.
void march_sky_run_portable(const PaddedLattice& pad, const SkyRun& r, double* tau_out) {
  int steps = 0;
  for (int l = 0; l < kSkyLanes; ++l) steps = std::max(steps, r.n[l]);
  const std::ptrdiff_t W = pad.w, WH = static_cast<std::ptrdiff_t>(pad.w) * pad.h;
  double tau[kSkyLanes] = {};
  for (int i = 0; i < steps; ++i) {
    const SkySample smp = sky_sample(r, i, pad.w, pad.w * pad.h);
    const float* a0 = pad.origin() + r.first + smp.offset;
    int live = 0;
    for (int l = 0; l < kSkyLanes; ++l) {
      const bool active = i < r.n[l] && tau[l] <= kSkyDepthCut;
      live += active;
      const float* a = a0 + l;
      const float c00 = a[0] + smp.fx * (a[1] - a[0]);
      const float c10 = a[W] + smp.fx * (a[W + 1] - a[W]);
      const float c01 = a[WH] + smp.fx * (a[WH + 1] - a[WH]);
      const float c11 = a[WH + W] + smp.fx * (a[WH + W + 1] - a[WH + W]);
      const float c0 = c00 + smp.fy * (c10 - c00);
      const float c1 = c01 + smp.fy * (c11 - c01);
      const float value = c0 + smp.fz * (c1 - c0);
      if (active) tau[l] += static_cast<double>(value) * static_cast<double>(sky_weight(r, l, i));
    }
    if (live == 0) break;
  }
  for (int l = 0; l < kSkyLanes; ++l) tau_out[l] = tau[l];
}

#ifdef CUMULI_X86_SKY
__attribute__((target("avx2"), always_inline)) inline __m256 lerp(__m256 a, __m256 b, __m256 f) {
  return _mm256_add_ps(a, _mm256_mul_ps(f, _mm256_sub_ps(b, a)));  // a + f·(b − a), as in C++
}

// march_sky_run_portable for the eight lanes from `base` in AVX2 registers: the same IEEE
// operations lane by lane (no FMA), so the same bits.
__attribute__((target("avx2"))) void march_sky_half_avx2(const PaddedLattice& pad, const SkyRun& r,
                                                         int base, double* tau_out) {
  int steps = 0;
  for (int l = base; l < base + 8; ++l) steps = std::max(steps, r.n[l]);
  const std::ptrdiff_t W = pad.w, WH = static_cast<std::ptrdiff_t>(pad.w) * pad.h;
  const __m256i n = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(r.n + base));
  const __m256i last = _mm256_sub_epi32(n, _mm256_set1_epi32(1));  // a lane's last sample
  const __m256 last_w = _mm256_loadu_ps(r.last + base), dt = _mm256_set1_ps(r.dt);
  const __m256d cut = _mm256_set1_pd(kSkyDepthCut);
  __m256d tau_lo = _mm256_setzero_pd(), tau_hi = _mm256_setzero_pd();
  for (int i = 0; i < steps; ++i) {
    const __m256i at = _mm256_set1_epi32(i);
    const __m256 before_last = _mm256_castsi256_ps(_mm256_cmpgt_epi32(last, at));
    const __m256 is_last = _mm256_castsi256_ps(_mm256_cmpeq_epi32(last, at));
    const __m256 wgt = _mm256_or_ps(_mm256_and_ps(before_last, dt), _mm256_and_ps(is_last, last_w));
    // A lane adds value·weight while on its ray and under the cut, +0 after (τ unchanged).
    const __m256i on_ray = _mm256_cmpgt_epi32(n, at);
    const __m256d act_lo =
        _mm256_and_pd(_mm256_cmp_pd(tau_lo, cut, _CMP_LE_OQ),
                      _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(on_ray))));
    const __m256d act_hi = _mm256_and_pd(
        _mm256_cmp_pd(tau_hi, cut, _CMP_LE_OQ),
        _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_extracti128_si256(on_ray, 1))));
    if ((_mm256_movemask_pd(act_lo) | _mm256_movemask_pd(act_hi)) == 0) break;
    const SkySample smp = sky_sample(r, i, pad.w, pad.w * pad.h);
    const float* a = pad.origin() + r.first + smp.offset + base;
    const __m256 fx = _mm256_set1_ps(smp.fx), fy = _mm256_set1_ps(smp.fy),
                 fz = _mm256_set1_ps(smp.fz);
    const __m256 c00 = lerp(_mm256_loadu_ps(a), _mm256_loadu_ps(a + 1), fx);
    const __m256 c10 = lerp(_mm256_loadu_ps(a + W), _mm256_loadu_ps(a + W + 1), fx);
    const __m256 c01 = lerp(_mm256_loadu_ps(a + WH), _mm256_loadu_ps(a + WH + 1), fx);
    const __m256 c11 = lerp(_mm256_loadu_ps(a + WH + W), _mm256_loadu_ps(a + WH + W + 1), fx);
    const __m256 value = lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz);
    tau_lo = _mm256_add_pd(
        tau_lo, _mm256_and_pd(act_lo, _mm256_mul_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(value)),
                                                    _mm256_cvtps_pd(_mm256_castps256_ps128(wgt)))));
    tau_hi = _mm256_add_pd(
        tau_hi,
        _mm256_and_pd(act_hi, _mm256_mul_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(value, 1)),
                                            _mm256_cvtps_pd(_mm256_extractf128_ps(wgt, 1)))));
  }
  _mm256_storeu_pd(tau_out + base, tau_lo);
  _mm256_storeu_pd(tau_out + base + 4, tau_hi);
}

__attribute__((target("avx2"))) void march_sky_run_avx2(const PaddedLattice& pad, const SkyRun& r,
                                                        double* tau_out) {
  static_assert(kSkyLanes % 8 == 0, "whole AVX2 registers of lanes");
  for (int base = 0; base < kSkyLanes; base += 8) march_sky_half_avx2(pad, r, base, tau_out);
}

__attribute__((target("avx512f"), always_inline)) inline __m512 lerp(__m512 a, __m512 b, __m512 f) {
  return _mm512_add_ps(a, _mm512_mul_ps(f, _mm512_sub_ps(b, a)));  // a + f·(b − a), as in C++
}

// Zero-masked conversion and extracts (the same values as the plain ones and the 512→256 cast,
// about whose undefined pass-through registers GCC 12 warns).
__attribute__((target("avx512f"), always_inline)) inline __m512d to_double(__m256 x) {
  return _mm512_maskz_cvtps_pd(0xFF, x);
}
template <int half>
__attribute__((target("avx512f"), always_inline)) inline __m256 half_of(__m512 x) {
  return _mm256_castpd_ps(_mm512_maskz_extractf64x4_pd(0xF, _mm512_castps_pd(x), half));
}

// march_sky_run_portable with the sixteen lanes in AVX-512 registers: the same IEEE operations
// lane by lane (no FMA: -ffp-contract=off), so the same bits; an inactive lane adds nothing.
__attribute__((target("avx512f"))) void march_sky_run_avx512(const PaddedLattice& pad,
                                                             const SkyRun& r, double* tau_out) {
  static_assert(kSkyLanes == 16, "one AVX-512 register of lanes");
  int steps = 0;
  for (int l = 0; l < kSkyLanes; ++l) steps = std::max(steps, r.n[l]);
  const std::ptrdiff_t W = pad.w, WH = static_cast<std::ptrdiff_t>(pad.w) * pad.h;
  const __m512i n = _mm512_loadu_si512(r.n);
  const __m512i last = _mm512_sub_epi32(n, _mm512_set1_epi32(1));  // a lane's last sample
  const __m512 last_w = _mm512_loadu_ps(r.last), dt = _mm512_set1_ps(r.dt);
  const __m512d cut = _mm512_set1_pd(kSkyDepthCut);
  __m512d tau_lo = _mm512_setzero_pd(), tau_hi = _mm512_setzero_pd();
  for (int i = 0; i < steps; ++i) {
    const __m512i at = _mm512_set1_epi32(i);
    const __mmask16 before_last = _mm512_cmpgt_epi32_mask(last, at);
    const __mmask16 is_last = _mm512_cmpeq_epi32_mask(last, at);
    const __m512 wgt = _mm512_mask_mov_ps(_mm512_maskz_mov_ps(before_last, dt), is_last, last_w);
    const __mmask16 on_ray = _mm512_cmpgt_epi32_mask(n, at);
    const __mmask8 act_lo = static_cast<__mmask8>(_mm512_cmp_pd_mask(tau_lo, cut, _CMP_LE_OQ) &
                                                  static_cast<__mmask8>(on_ray & 0xFF));
    const __mmask8 act_hi = static_cast<__mmask8>(_mm512_cmp_pd_mask(tau_hi, cut, _CMP_LE_OQ) &
                                                  static_cast<__mmask8>(on_ray >> 8));
    if ((act_lo | act_hi) == 0) break;
    const SkySample smp = sky_sample(r, i, pad.w, pad.w * pad.h);
    const float* a = pad.origin() + r.first + smp.offset;
    const __m512 fx = _mm512_set1_ps(smp.fx), fy = _mm512_set1_ps(smp.fy),
                 fz = _mm512_set1_ps(smp.fz);
    const __m512 c00 = lerp(_mm512_loadu_ps(a), _mm512_loadu_ps(a + 1), fx);
    const __m512 c10 = lerp(_mm512_loadu_ps(a + W), _mm512_loadu_ps(a + W + 1), fx);
    const __m512 c01 = lerp(_mm512_loadu_ps(a + WH), _mm512_loadu_ps(a + WH + 1), fx);
    const __m512 c11 = lerp(_mm512_loadu_ps(a + WH + W), _mm512_loadu_ps(a + WH + W + 1), fx);
    const __m512 value = lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz);
    const __m512d p_lo = _mm512_mul_pd(to_double(half_of<0>(value)), to_double(half_of<0>(wgt)));
    const __m512d p_hi = _mm512_mul_pd(to_double(half_of<1>(value)), to_double(half_of<1>(wgt)));
    tau_lo = _mm512_mask_add_pd(tau_lo, act_lo, tau_lo, p_lo);
    tau_hi = _mm512_mask_add_pd(tau_hi, act_hi, tau_hi, p_hi);
  }
  _mm512_storeu_pd(tau_out, tau_lo);
  _mm512_storeu_pd(tau_out + 8, tau_hi);
}
#endif

// One direction of the sphere's quadrature for the sky march: its step in voxel units and the
// box faces its rays leave by.
struct SkyDirection {
  glm::vec3 du, inv_d, face;
};

// A run's rays along `dir` from its lanes' voxel centres (cx, cy, cz) to where they leave the box:
// from inside, the nearest face ahead on each axis. Lanes not in `lanes` get no ray. Branch-free
// over the lanes, so that it vectorises.
SKY_VEC_CLONES void sky_run_rays(const float* cx, const float* cy, const float* cz,
                                 const int* marched, const SkyDirection& dir, float dt, SkyRun& r) {
  for (int l = 0; l < kSkyLanes; ++l) {
    const float len =
        std::min(std::min((dir.face.x - cx[l]) * dir.inv_d.x, (dir.face.y - cy[l]) * dir.inv_d.y),
                 (dir.face.z - cz[l]) * dir.inv_d.z);
    const int n = std::max(1, static_cast<int>(std::ceil(len / dt)));
    r.n[l] = marched[l] ? n : 0;
    r.last[l] = marched[l] ? len - static_cast<float>(n - 1) * dt : 0.0f;
  }
}

// vw[l] = w·e^{−τ[l]}: one direction's visibility per lane (w its quadrature weight); e^{−τ} by
// exp_neg, in plain operations, so that the lanes vectorise with the same bits on every
// instruction set.
SKY_VEC_CLONES void direction_visibility(const double* tau, float w, double* vw) {
  for (int l = 0; l < kSkyLanes; ++l)
    vw[l] = static_cast<double>(exp_neg(static_cast<float>(tau[l]))) * static_cast<double>(w);
}

// vis[c][l] += vw[k][l]·y[k][c] for the nk directions of a block, in their order (each
// coefficient's sums held in registers over the block rather than loaded and stored per
// direction; the same sums, the same bits).
SKY_VEC_CLONES void add_block_visibility(const double (*vw)[kSkyLanes], int nk, const float* y,
                                         int nc, double (*vis)[kSkyLanes]) {
  for (int c = 0; c < nc; ++c) {
    double acc[kSkyLanes];
    for (int l = 0; l < kSkyLanes; ++l) acc[l] = vis[c][l];
    for (int k = 0; k < nk; ++k) {
      const double yc = static_cast<double>(y[k * nc + c]);
      for (int l = 0; l < kSkyLanes; ++l) acc[l] += vw[k][l] * yc;
    }
    for (int l = 0; l < kSkyLanes; ++l) vis[c][l] = acc[l];
  }
}

// Directions whose visibilities add_block_visibility takes together.
constexpr int kSkyBlock = 16;

// The lanes' τ by the kernel of the SIMD level in use (the same bits either way).
void march_sky_run(const PaddedLattice& pad, const SkyRun& r, double* tau) {
#ifdef CUMULI_X86_SKY
  if (simd_level() == SimdLevel::Avx512) return march_sky_run_avx512(pad, r, tau);
  if (simd_level() != SimdLevel::Scalar) return march_sky_run_avx2(pad, r, tau);
#endif
  march_sky_run_portable(pad, r, tau);
}

// Lattice rays stand for the sphere's directions only where the voxels are near cubes.
constexpr float kLatticeMaxAspect = 1.1f;

}  // namespace

LargeVector<float> sky_visibility(const float* ext, const VolumeGrid& g, int order, int n_theta,
                                  float step_voxels, int threads, SkyRays rays) {
  g.validate();
  if (order < 1 || order > kMaxShOrder) throw std::invalid_argument("sh_order must be in [1, 4]");
  if (!(step_voxels > 0.0f)) throw std::invalid_argument("step must be > 0");
  const SphereQuadrature quad(n_theta);
  const int nc = order * order;
  const std::size_t ndir = quad.dirs.size();
  LargeVector<float> basis(ndir * nc);
  for (std::size_t k = 0; k < ndir; ++k) sh_eval(order, quad.dirs[k], &basis[k * nc]);
  const glm::vec3 vs = g.voxel_size();
  const float dt = step_voxels * std::min(vs.x, std::min(vs.y, vs.z));
  const std::size_t nv = g.voxels();
  LargeVector<float> out(nv * static_cast<std::size_t>(nc), 0.0f);
  const glm::vec3 inv_vs = 1.0f / vs;
  // Voxels with no medium within one voxel are never read where light scatters: they get the
  // unoccluded sky (V = 1: V_0 = √4π, the other coefficients 0).
  const float open = 3.5449077018110318f;  // √(4π)
  // The 3×3×3 neighbourhood's "any medium", as three one-axis dilations.
  LargeVector<unsigned char> near(nv), pass(nv);
  for (std::size_t v = 0; v < nv; ++v) near[v] = ext[v] > 0.0f;
  const std::size_t strides[3] = {1, static_cast<std::size_t>(g.w),
                                  static_cast<std::size_t>(g.w) * static_cast<std::size_t>(g.h)};
  const int dims[3] = {g.w, g.h, g.d};
  for (int a = 0; a < 3; ++a) {
    const std::size_t st = strides[a];
    const std::size_t n_a = static_cast<std::size_t>(dims[a]);
    parallel_chunks(nv, threads, [&](std::size_t vb, std::size_t ve) {
      for (std::size_t v = vb; v < ve; ++v) {
        const std::size_t c = (v / st) % n_a;
        unsigned char m = near[v];
        if (c > 0) m |= near[v - st];
        if (c + 1 < n_a) m |= near[v + st];
        pass[v] = m;
      }
    });
    near.swap(pass);
  }
  // V_m = Σ_k w_k y_m(ω_k) e^{−τ(x, ω_k)}: a voxel's visibility moments.
  const auto finish = [&](std::size_t v, const double* vis) {
    for (int c = 0; c < nc; ++c) out[v * nc + c] = static_cast<float>(vis[c]);
  };
  const auto open_sky = [&](std::size_t v) { out[v * nc] = open; };
  const float aspect = std::max(vs.x, std::max(vs.y, vs.z)) / std::min(vs.x, std::min(vs.y, vs.z));
  if (rays == SkyRays::Lattice && aspect <= kLatticeMaxAspect) {
    // τ of every voxel along each lattice direction by its recurrence, a few directions at a
    // time; each voxel's moments summed over the directions in their order, so the result does
    // not depend on the thread count.
    const std::vector<LatticeDirection> dirs = lattice_directions();
    const std::size_t nd = dirs.size();
    LargeVector<float> lbasis(nd * nc);
    for (std::size_t k = 0; k < nd; ++k)
      sh_eval(order, glm::normalize(glm::vec3(dirs[k].step) * vs), &lbasis[k * nc]);
    const std::size_t batch =
        std::min<std::size_t>(nd, std::max<std::size_t>(resolve_threads(threads, nd), 1));
    LargeVector<float> depth(batch * nv);
    LargeVector<float> wy(nd * nc);  // weight × basis, per direction
    for (std::size_t k = 0; k < nd; ++k)
      for (int c = 0; c < nc; ++c) wy[k * nc + c] = dirs[k].weight * lbasis[k * nc + c];
    LargeVector<float> moments(static_cast<std::size_t>(nc) * nv, 0.0f);  // [c][v]
    constexpr std::size_t kChunk = 4096;
    const std::size_t chunks = (nv + kChunk - 1) / kChunk;
    for (std::size_t k0 = 0; k0 < nd; k0 += batch) {
      const std::size_t kn = std::min(batch, nd - k0);
      parallel_for(kn, threads, [&](std::size_t j) {
        lattice_optical_depth(ext, g, dirs[k0 + j].step, depth.data() + j * nv);
      });
      // Each voxel's sums run over the directions in their order: the same on any thread count.
      parallel_for(chunks, threads, [&](std::size_t b) {
        float scratch[kChunk];
        const std::size_t vb = b * kChunk, ve = std::min(nv, vb + kChunk);
        for (std::size_t j = 0; j < kn; ++j)
          add_visibility(moments.data(), nv, depth.data() + j * nv, vb, ve, &wy[(k0 + j) * nc], nc,
                         scratch);
      });
    }
    parallel_for(nv, threads, [&](std::size_t v) {
      if (!near[v]) {
        open_sky(v);
        return;
      }
      double vis[kMaxShOrder * kMaxShOrder];
      for (int c = 0; c < nc; ++c) vis[c] = moments[static_cast<std::size_t>(c) * nv + v];
      finish(v, vis);
    });
    return out;
  }
  // Runs of kSkyLanes neighbours along x from each voxel with medium near that no earlier run
  // holds; a run's lanes past the row or with no medium near march nothing.
  const PaddedLattice pad(ext, g, 2 + static_cast<int>(std::ceil(0.5f * step_voxels)));
  struct Run {
    int x0, y, z;
    unsigned lanes;  // bit l: voxel x0 + l is marched
  };
  std::vector<Run> runs;
  for (int z = 0; z < g.d; ++z)
    for (int y = 0; y < g.h; ++y) {
      const std::size_t row = (static_cast<std::size_t>(z) * g.h + y) * g.w;
      for (int x = 0; x < g.w;) {
        if (!near[row + x]) {
          open_sky(row + x);
          ++x;
          continue;
        }
        Run run{x, y, z, 0u};
        for (int l = 0; l < kSkyLanes && x + l < g.w; ++l) {
          if (near[row + x + l])
            run.lanes |= 1u << l;
          else
            open_sky(row + x + l);
        }
        runs.push_back(run);
        x += kSkyLanes;
      }
    }
  std::vector<SkyDirection> directions(ndir);
  for (std::size_t k = 0; k < ndir; ++k) {
    const glm::vec3 d = quad.dirs[k];
    SkyDirection& dir = directions[k];
    dir.du = (dt * d) * inv_vs;
    dir.inv_d = 1.0f / d;
    for (int a = 0; a < 3; ++a)  // ±∞ for a zero component: never the nearest face
      dir.face[a] = dir.inv_d[a] >= 0.0f ? g.box.hi[a] : g.box.lo[a];
  }
  parallel_for(runs.size(), threads, [&](std::size_t index) {
    const Run& run = runs[index];
    float cx[kSkyLanes], cy[kSkyLanes], cz[kSkyLanes];
    int marched[kSkyLanes];
    for (int l = 0; l < kSkyLanes; ++l) {
      const glm::vec3 c = g.centre(run.x0 + l, run.y, run.z);
      cx[l] = c.x, cy[l] = c.y, cz[l] = c.z;
      marched[l] = static_cast<int>(run.lanes >> l & 1u);
    }
    double vis[kMaxShOrder * kMaxShOrder][kSkyLanes] = {};  // [coefficient][lane]
    SkyRun r;
    r.first = pad.index(run.x0, run.y, run.z);
    r.dt = dt;
    double vw[kSkyBlock][kSkyLanes];  // a block of directions' w·e^{−τ} per lane
    int in_block = 0;
    for (std::size_t k = 0; k < ndir; ++k) {
      r.du = directions[k].du;
      sky_run_rays(cx, cy, cz, marched, directions[k], dt, r);
      double tau[kSkyLanes];
      march_sky_run(pad, r, tau);
      direction_visibility(tau, quad.weights[k], vw[in_block]);
      if (++in_block == kSkyBlock || k + 1 == ndir) {
        add_block_visibility(vw, in_block, &basis[(k + 1 - in_block) * nc], nc, vis);
        in_block = 0;
      }
    }
    const std::size_t row = (static_cast<std::size_t>(run.z) * g.h + run.y) * g.w;
    for (int l = 0; l < kSkyLanes; ++l) {
      if (!(run.lanes >> l & 1u)) continue;
      double moments[kMaxShOrder * kMaxShOrder];
      for (int c = 0; c < nc; ++c) moments[c] = vis[c][l];
      finish(row + run.x0 + l, moments);
    }
  });
  return out;
}

LargeVector<float> physical_grid(const float* ext, std::size_t voxels, const float* phi,
                                 int phi_channels, const float* sky_e, double cell,
                                 double gain_depth, double sun_gain, double sky_gain, int threads) {
  if (phi != nullptr && phi_channels != 1 && phi_channels != 4)
    throw std::invalid_argument("phi must have 1 or 4 channels");
  if (phi != nullptr && phi_channels == 1 && sky_e != nullptr)
    throw std::invalid_argument("a sky's light needs the fluence's sky channels");
  LargeVector<float> out(voxels * 4, 0.0f);
  parallel_chunks(voxels, threads, [&](std::size_t vb, std::size_t ve) {
    for (std::size_t v = vb; v < ve; ++v) {
      float* o = &out[v * 4];
      if (phi == nullptr) {
        if (sky_e != nullptr)
          for (int c = 0; c < 3; ++c) o[1 + c] = sky_e[v * 3 + c];
        continue;
      }
      // As lattice_gains: the rise in double, each gain rounded to float.
      const double rise =
          gain_depth == 0.0
              ? 1.0
              : -std::expm1((-std::max(static_cast<double>(ext[v]), 0.0) * cell) / gain_depth);
      const auto gain = [&](double g) {
        return gain_depth == 0.0 ? static_cast<float>(g)
                                 : static_cast<float>(1.0 + (g - 1.0) * rise);
      };
      const float* f = phi + v * static_cast<std::size_t>(phi_channels);
      o[0] = gain(sun_gain) * f[0];
      if (sky_e != nullptr) {
        const float g = gain(sky_gain);
        for (int c = 0; c < 3; ++c) o[1 + c] = g * (sky_e[v * 3 + c] + f[1 + c]);
      }
    }
  });
  return out;
}

LargeVector<float> sky_irradiance_from(const float* visibility, std::size_t voxels,
                                       const float* sky_coeffs, int order, int threads) {
  if (order < 1 || order > kMaxShOrder) throw std::invalid_argument("sh_order must be in [1, 4]");
  const int nc = order * order;
  LargeVector<float> out(voxels * 3);
  parallel_for(voxels, threads, [&](std::size_t v) {
    const float* vis = visibility + v * nc;
    for (int ch = 0; ch < 3; ++ch) {
      double e = 0.0;
      for (int c = 0; c < nc; ++c)
        e += static_cast<double>(sky_coeffs[ch * nc + c]) * static_cast<double>(vis[c]);
      out[v * 3 + ch] = static_cast<float>(std::max(0.0, e));
    }
  });
  return out;
}

LargeVector<float> sky_irradiance(const float* ext, const VolumeGrid& g, const float* sky_coeffs,
                                  int order, int n_theta, float step_voxels, int threads,
                                  SkyRays rays) {
  const LargeVector<float> vis = sky_visibility(ext, g, order, n_theta, step_voxels, threads, rays);
  return sky_irradiance_from(vis.data(), g.voxels(), sky_coeffs, order);
}

// ---------------------------------------------------------------------------------------------
// Diffusion

namespace {
constexpr float kMediumThickness = 0.02f;  // σt·h below this: an empty cell

float boost(float x) {  // 2 sinh(x/2)/x, the thick-cell source factor (→ 1 for thin cells)
  if (x < 1e-4f) return 1.0f;
  x = std::min(x, 40.0f);
  return 2.0f * std::sinh(0.5f * x) / x;
}
}  // namespace

LargeVector<float> diffusion_sources(const float* ext, const VolumeGrid& g, const float* sun_t,
                                     glm::vec3 to_sun, const float* sky_e, float albedo,
                                     int threads) {
  const std::size_t slice = static_cast<std::size_t>(g.w) * g.h;
  const int ch = sky_e != nullptr ? 4 : 1;
  LargeVector<float> q(g.voxels() * ch, 0.0f);
  const glm::vec3 h = g.voxel_size();
  const glm::vec3 s = glm::normalize(to_sun);
  const float ell_sun =
      h.x * h.y * h.z /
      (std::abs(s.x) * h.y * h.z + std::abs(s.y) * h.x * h.z + std::abs(s.z) * h.x * h.y);
  const float ell_sky = 2.0f * std::min(h.x, std::min(h.y, h.z)) / 3.0f;
  parallel_for(static_cast<std::size_t>(g.d), threads, [&](std::size_t z) {
    for (std::size_t v = z * slice; v < (z + 1) * slice; ++v) {
      const float sigma = ext[v];
      if (!(sigma > 0.0f)) continue;
      q[v * ch] = albedo * sigma * sun_t[v] * boost(sigma * ell_sun);
      if (sky_e != nullptr) {
        const float b = albedo * sigma * boost(sigma * ell_sky);
        for (int c = 0; c < 3; ++c) q[v * ch + 1 + c] = b * sky_e[v * 3 + c];
      }
    }
  });
  return q;
}

namespace {

// weight·3D·|Q1| per cell (0 outside the medium): Q1 = ϖσ·T·ḡ the first moment of the collided
// sun light per unit irradiance, D = 1/(3σt') — the forward-scattered flux the diffusion's
// source −∇·(3D·Q1) carries, and a part of the diffuse flux E = −D∇φ + 3D·Q1.
LargeVector<float> sun_flux_strength(const float* ext, std::size_t n, const unsigned char* medium,
                                     const float* sun_t, float albedo, float mean_cosine,
                                     float weight) {
  LargeVector<float> f(n, 0.0f);
  for (std::size_t i = 0; i < n; ++i) {
    if (!medium[i]) continue;
    const float st = ext[i];
    const float stp = (1.0f - albedo) * st + albedo * st * (1.0f - mean_cosine);
    f[i] = weight * albedo * st * sun_t[i] * mean_cosine / std::max(stp, 1e-12f);
  }
  return f;
}

}  // namespace

void add_sun_flux_source(LargeVector<float>& q, int channels, const float* ext, const VolumeGrid& g,
                         const float* sun_t, glm::vec3 to_sun, float albedo, float mean_cosine,
                         float weight) {
  if (weight == 0.0f) return;
  const int W = g.w, H = g.h, Dd = g.d;
  const std::size_t n = g.voxels();
  if (q.size() != n * static_cast<std::size_t>(channels))
    throw std::invalid_argument("source size must be voxels × channels");
  const glm::vec3 hv = g.voxel_size();
  const float h[3] = {hv.x, hv.y, hv.z};
  const float hmin = std::min(h[0], std::min(h[1], h[2]));
  const glm::vec3 dir = -glm::normalize(to_sun);  // the way the light travels
  const float s[3] = {dir.x, dir.y, dir.z};
  LargeVector<unsigned char> medium(n);
  for (std::size_t i = 0; i < n; ++i) medium[i] = ext[i] * hmin > kMediumThickness;
  const LargeVector<float> f =
      sun_flux_strength(ext, n, medium.data(), sun_t, albedo, mean_cosine, weight);
  const std::size_t stride[3] = {1, static_cast<std::size_t>(W), static_cast<std::size_t>(W) * H};
  const int dims[3] = {W, H, Dd};
  for (std::size_t i = 0; i < n; ++i) {
    if (!medium[i]) continue;
    const int c[3] = {static_cast<int>(i % W), static_cast<int>((i / W) % H),
                      static_cast<int>(i / (static_cast<std::size_t>(W) * H))};
    for (int a = 0; a < 3; ++a) {
      if (c[a] + 1 >= dims[a]) continue;
      const std::size_t j = i + stride[a];
      if (!medium[j]) continue;
      // The flux source through the face between two medium cells: what leaves i enters j.
      const float face = 0.5f * (f[i] + f[j]) * s[a] / h[a];
      q[i * channels] -= face;
      q[j * channels] += face;
    }
  }
}

namespace {

// The diffusion's lattice: which cells hold the medium and their diffusion coefficient
// D = 1/(3σt'), σt' = σa + ϖσt(1 − ḡ) the reduced extinction.
struct DiffusionLattice {
  int W, H, Dd;
  std::size_t n;
  float h[3];
  std::size_t stride[3];
  int dims[3];
  LargeVector<unsigned char> medium;
  LargeVector<float> D;

  DiffusionLattice(const float* ext, const VolumeGrid& g, const DiffusionParams& p)
      : W(g.w), H(g.h), Dd(g.d), n(g.voxels()), medium(g.voxels()), D(g.voxels(), 0.0f) {
    const glm::vec3 hv = g.voxel_size();
    h[0] = hv.x;
    h[1] = hv.y;
    h[2] = hv.z;
    const float hmin = std::min(h[0], std::min(h[1], h[2]));
    stride[0] = 1;
    stride[1] = static_cast<std::size_t>(W);
    stride[2] = static_cast<std::size_t>(W) * H;
    dims[0] = W;
    dims[1] = H;
    dims[2] = Dd;
    for (std::size_t i = 0; i < n; ++i) {
      medium[i] = ext[i] * hmin > kMediumThickness;
      if (!medium[i]) continue;
      const float st = ext[i], sa = (1.0f - p.albedo) * st;
      const float stp = sa + p.albedo * st * (1.0f - p.mean_cosine);
      D[i] = 1.0f / (3.0f * std::max(stp, 1e-12f));
    }
  }
  // The conductance of the face between medium cells i and j = i + stride[a].
  float conductance(std::size_t i, std::size_t j, int a) const {
    return 2.0f * D[i] * D[j] / (D[i] + D[j]) / (h[a] * h[a]);
  }
  // The Marshak boundary's leak from a medium cell of coefficient d through a face ⊥ axis a.
  float leak(float d, int a) const { return 2.0f * d / (h[a] * (h[a] + 4.0f * d)); }
};

// The old solve (solver jacobi): conjugate gradients preconditioned by the diagonal over the
// whole lattice, into out (`channels` per voxel; the medium cells' values).
void fluence_jacobi(const DiffusionLattice& L, const float* ext, const float* source, int channels,
                    const DiffusionParams& p, int threads, LargeVector<float>& out) {
  const std::size_t n = L.n;
  const int W = L.W, H = L.H;
  const auto& stride = L.stride;
  const auto& dims = L.dims;
  const auto& h = L.h;
  const auto& medium = L.medium;
  const auto& D = L.D;
  LargeVector<float> diag(n, 1.0f);
  for (std::size_t i = 0; i < n; ++i)
    if (medium[i]) diag[i] = (1.0f - p.albedo) * ext[i];
  // Face conductances (to the + neighbour along each axis) and the diagonal.
  LargeVector<float> cond(3 * n, 0.0f);
  auto coord = [&](std::size_t i, int a) {
    return a == 0   ? static_cast<int>(i % W)
           : a == 1 ? static_cast<int>((i / W) % H)
                    : static_cast<int>(i / (static_cast<std::size_t>(W) * H));
  };
  auto leak = [&](float d, float ha) { return 2.0f * d / (ha * (ha + 4.0f * d)); };
  for (std::size_t i = 0; i < n; ++i) {
    if (!medium[i]) continue;
    for (int a = 0; a < 3; ++a) {
      if (coord(i, a) + 1 < dims[a] && medium[i + stride[a]]) {
        const std::size_t j = i + stride[a];
        cond[3 * i + a] = 2.0f * D[i] * D[j] / (D[i] + D[j]) / (h[a] * h[a]);
      }
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!medium[i]) continue;
    for (int a = 0; a < 3; ++a) {
      const int c = coord(i, a);
      const bool plus = c + 1 < dims[a] && medium[i + stride[a]];
      const bool minus = c > 0 && medium[i - stride[a]];
      diag[i] += plus ? cond[3 * i + a] : leak(D[i], h[a]);
      diag[i] += minus ? cond[3 * (i - stride[a]) + a] : leak(D[i], h[a]);
    }
  }
  // y = A·x at cell i (0 outside the medium).
  auto apply_at = [&](const LargeVector<double>& x, std::size_t i) {
    if (!medium[i]) return 0.0;
    double s = static_cast<double>(diag[i]) * x[i];
    for (int a = 0; a < 3; ++a) {
      if (cond[3 * i + a] > 0.0f) s -= static_cast<double>(cond[3 * i + a]) * x[i + stride[a]];
      if (coord(i, a) > 0 && medium[i - stride[a]])
        s -= static_cast<double>(cond[3 * (i - stride[a]) + a]) * x[i - stride[a]];
    }
    return s;
  };
  // Preconditioned conjugate gradients with each iteration's element-wise updates and dot
  // products fused into two passes over fixed blocks (sums per block, added in block order: the
  // result does not depend on the thread count). One channel's solve, on `inner` threads, into
  // x; `from` (optional) the solution of channel `from_c` to start from, scaled by the
  // least-squares ratio of the two channels' sources.
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  auto b_of = [&](std::size_t i, int c) {
    return medium[i] ? static_cast<double>(source[i * channels + c]) : 0.0;
  };
  auto solve = [&](int c, const LargeVector<double>* from, int from_c, LargeVector<double>& x,
                   int inner) {
    std::vector<std::array<double, 2>> part(blocks);
    auto sums = [&](auto&& body) {  // body(begin, end) → {Σ, Σ} over its block
      parallel_for(blocks, inner, [&](std::size_t b) {
        part[b] = body(b * kBlock, std::min(n, (b + 1) * kBlock));
      });
      std::array<double, 2> total{0.0, 0.0};
      for (const auto& t : part) {
        total[0] += t[0];
        total[1] += t[1];
      }
      return total;
    };
    LargeVector<double> r(n), z(n), q(n), Ap(n);
    x.assign(n, 0.0);
    double scale = 0.0;
    if (from != nullptr) {
      const auto bb = sums([&](std::size_t i0, std::size_t i1) {
        std::array<double, 2> t{0.0, 0.0};
        for (std::size_t i = i0; i < i1; ++i) {
          const double bf = b_of(i, from_c);
          t[0] += b_of(i, c) * bf;
          t[1] += bf * bf;
        }
        return t;
      });
      if (bb[1] > 0.0) scale = bb[0] / bb[1];
      if (scale != 0.0) parallel_for(n, inner, [&](std::size_t i) { x[i] = scale * (*from)[i]; });
    }
    const auto init = sums([&](std::size_t i0, std::size_t i1) {
      std::array<double, 2> t{0.0, 0.0};
      for (std::size_t i = i0; i < i1; ++i) {
        const double b = b_of(i, c);
        r[i] = b - (scale != 0.0 ? apply_at(x, i) : 0.0);
        z[i] = r[i] / diag[i];
        q[i] = z[i];
        t[0] += r[i] * z[i];
        t[1] += b * b;
      }
      return t;
    });
    double rz = init[0];
    const double bnorm = std::sqrt(init[1]);
    if (!(bnorm > 0.0)) return;
    for (int it = 0; it < p.max_iterations; ++it) {
      const double qAq = sums([&](std::size_t i0, std::size_t i1) {
        std::array<double, 2> t{0.0, 0.0};
        for (std::size_t i = i0; i < i1; ++i) {
          Ap[i] = apply_at(q, i);
          t[0] += q[i] * Ap[i];
        }
        return t;
      })[0];
      if (!(qAq > 0.0)) break;
      const double alpha = rz / qAq;
      const auto rr = sums([&](std::size_t i0, std::size_t i1) {
        std::array<double, 2> t{0.0, 0.0};
        for (std::size_t i = i0; i < i1; ++i) {
          x[i] += alpha * q[i];
          r[i] -= alpha * Ap[i];
          z[i] = r[i] / diag[i];
          t[0] += r[i] * r[i];
          t[1] += r[i] * z[i];
        }
        return t;
      });
      if (std::sqrt(rr[0]) <= p.tolerance * bnorm) break;
      const double beta = rr[1] / rz;
      rz = rr[1];
      parallel_for(n, inner, [&](std::size_t i) { q[i] = z[i] + beta * q[i]; });
    }
  };
  // The channels' solves: the sun's and the sky's first (red) together, one thread each, then
  // the sky's green and blue, both started from the red solution (the sky's colour channels
  // differ mostly by a factor: the conjugate gradients then only correct the difference). A
  // solve on one thread saves each iteration's hand-offs between threads on a lattice this
  // small; the results are the same on any number of threads.
  std::vector<LargeVector<double>> xs(static_cast<std::size_t>(channels));
  auto round = [&](const std::vector<int>& cs, const LargeVector<double>* from, int from_c) {
    const bool apart = cs.size() > 1 && resolve_threads(threads, cs.size()) > 1;
    if (apart) {
      parallel_for(cs.size(), threads,
                   [&](std::size_t k) { solve(cs[k], from, from_c, xs[cs[k]], 1); });
    } else {
      for (int c : cs) solve(c, from, from_c, xs[c], threads);
    }
  };
  if (channels >= 2) {
    round({0, 1}, nullptr, 0);
    std::vector<int> rest;
    for (int c = 2; c < channels; ++c) rest.push_back(c);
    if (!rest.empty()) round(rest, &xs[1], 1);
  } else {
    round({0}, nullptr, 0);
  }
  for (int c = 0; c < channels; ++c)
    for (std::size_t i = 0; i < n; ++i)
      if (medium[i]) out[i * channels + c] = static_cast<float>(std::max(0.0, xs[c][i]));
}

// The medium cells as a CellSystem (in lattice order) and each one's lattice index; the rows
// are built over z-slices in parallel (each slice's rows start at the count of medium cells
// before it: the same system whatever the thread count).
CellSystem medium_system(const DiffusionLattice& L, const float* ext, const DiffusionParams& p,
                         int threads, LargeVector<std::size_t>& cells) {
  const std::size_t n = L.n;
  const std::size_t slice = static_cast<std::size_t>(L.W) * L.H;
  LargeVector<std::int32_t> at(n, -1);
  std::vector<std::size_t> first(static_cast<std::size_t>(L.Dd) + 1, 0);  // per slice
  cells.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (i % slice == 0) first[i / slice] = cells.size();
    if (L.medium[i]) {
      at[i] = static_cast<std::int32_t>(cells.size());
      cells.push_back(i);
    }
  }
  const auto none = static_cast<std::int32_t>(cells.size());
  CellSystem sys;
  sys.rows.resize(cells.size());
  parallel_for(static_cast<std::size_t>(L.Dd), threads, [&](std::size_t zz) {
    const int z = static_cast<int>(zz);
    std::size_t k = first[zz];
    for (int y = 0; y < L.H; ++y)
      for (int x = 0; x < L.W; ++x) {
        const std::size_t i = (static_cast<std::size_t>(z) * L.H + y) * L.W + x;
        if (!L.medium[i]) continue;
        CellSystem::Row& row = sys.rows[k++];
        const int c[3] = {x, y, z};
        float diag = (1.0f - p.albedo) * ext[i];
        for (int a = 0; a < 3; ++a) {
          const std::size_t s = L.stride[a];
          const bool plus = c[a] + 1 < L.dims[a] && L.medium[i + s];
          const bool minus = c[a] > 0 && L.medium[i - s];
          const float cp = plus ? L.conductance(i, i + s, a) : 0.0f;
          const float cm = minus ? L.conductance(i - s, i, a) : 0.0f;
          diag += plus ? cp : L.leak(L.D[i], a);
          diag += minus ? cm : L.leak(L.D[i], a);
          row.nb[a] = minus ? at[i - s] : none;
          row.cond[a] = cm;
          row.nb[3 + a] = plus ? at[i + s] : none;
          row.cond[3 + a] = cp;
        }
        row.diag = diag;
      }
  });
  return sys;
}

// The new solve (solver mic): conjugate gradients preconditioned by MIC(0), over the medium cells
// only, each channel on one thread, into out (`channels` per voxel; the medium cells' values).
void fluence_mic(const DiffusionLattice& L, const float* ext, const float* source, int channels,
                 const DiffusionParams& p, int threads, LargeVector<float>& out) {
  LargeVector<std::size_t> cells;
  const CellSystem sys = medium_system(L, ext, p, threads, cells);
  const MicFactor factor = mic_factor(sys);
  const std::size_t m = cells.size();
  // One channel's solve into xs[c] (m + 1 values); `from` (< 0: none) the channel whose solution
  // it starts from, scaled by the least-squares ratio of the two channels' sources.
  std::vector<LargeVector<double>> xs(static_cast<std::size_t>(channels));
  auto solve = [&](int c, int from) {
    LargeVector<double> b(m);
    for (std::size_t k = 0; k < m; ++k) b[k] = source[cells[k] * channels + c];
    LargeVector<double>& x = xs[c];
    x.assign(m + 1, 0.0);
    if (from >= 0) {
      double num = 0.0, den = 0.0;
      for (std::size_t k = 0; k < m; ++k) {
        const double bf = source[cells[k] * channels + from];
        num += b[k] * bf;
        den += bf * bf;
      }
      const double scale = den > 0.0 ? num / den : 0.0;
      for (std::size_t k = 0; k < m; ++k) x[k] = scale * xs[from][k];
    }
    solve_mic(sys, factor, b, x, p.tolerance, p.max_iterations);
    for (std::size_t k = 0; k < m; ++k)
      out[cells[k] * channels + c] = static_cast<float>(std::max(0.0, x[k]));
  };
  // As the Jacobi solve's: the sun's and the sky's red first, then green and blue from red.
  std::vector<int> first{0}, rest;
  if (channels >= 2) first.push_back(1);
  for (int c = 2; c < channels; ++c) rest.push_back(c);
  parallel_for(first.size(), threads, [&](std::size_t k) { solve(first[k], -1); });
  parallel_for(rest.size(), threads, [&](std::size_t k) { solve(rest[k], 1); });
}

}  // namespace

LargeVector<float> diffusion_fluence(const float* ext, const VolumeGrid& g, const float* source,
                                     int channels, const DiffusionParams& p, int threads) {
  g.validate();
  if (channels < 1 || channels > 8) throw std::invalid_argument("channels must be in [1, 8]");
  if (!(p.albedo >= 0.0f && p.albedo <= 1.0f))
    throw std::invalid_argument("albedo must be in [0, 1]");
  const DiffusionLattice L(ext, g, p);
  const std::size_t n = L.n;
  LargeVector<float> out(n * static_cast<std::size_t>(channels), 0.0f);
  if (p.solver == DiffusionSolver::mic)
    fluence_mic(L, ext, source, channels, p, threads, out);
  else
    fluence_jacobi(L, ext, source, channels, p, threads, out);
  // Empty cells next to the medium: the mean boundary value φ·4D/(h + 4D) of their medium
  // neighbours, so that lookups between a surface cell and an empty one see the surface value
  // (the medium cells' values are read only: the empty ones are written in place).
  parallel_for(static_cast<std::size_t>(L.Dd), threads, [&](std::size_t zz) {
    const int z = static_cast<int>(zz);
    float acc[8];
    for (int y = 0; y < L.H; ++y)
      for (int x = 0; x < L.W; ++x) {
        const std::size_t i = (static_cast<std::size_t>(z) * L.H + y) * L.W + x;
        if (L.medium[i]) continue;
        const int c[3] = {x, y, z};
        int count = 0;
        for (int ch = 0; ch < channels; ++ch) acc[ch] = 0.0f;
        for (int a = 0; a < 3; ++a) {
          for (int side = -1; side <= 1; side += 2) {
            const int cc = c[a] + side;
            if (cc < 0 || cc >= L.dims[a]) continue;
            const std::size_t j = side > 0 ? i + L.stride[a] : i - L.stride[a];
            if (!L.medium[j]) continue;
            const float f = 4.0f * L.D[j] / (L.h[a] + 4.0f * L.D[j]);
            for (int ch = 0; ch < channels; ++ch) acc[ch] += f * out[j * channels + ch];
            ++count;
          }
        }
        if (count > 0)
          for (int ch = 0; ch < channels; ++ch)
            out[i * channels + ch] = acc[ch] / static_cast<float>(count);
      }
  });
  return out;
}

LargeVector<float> diffusion_anisotropy(const float* ext, const VolumeGrid& g, const float* phi,
                                        int channels, const DiffusionParams& p, int threads,
                                        const float* sun_t, glm::vec3 to_sun, float forward) {
  g.validate();
  if (channels < 1 || channels > 8) throw std::invalid_argument("channels must be in [1, 8]");
  const DiffusionLattice L(ext, g, p);
  const std::size_t n = L.n;
  LargeVector<float> out(n * 3, 0.0f);
  auto at = [&](std::size_t i) { return static_cast<double>(phi[i * channels]); };
  // The forward-scattered flux's strength per cell and the way the light travels (none: 0).
  const bool streams = sun_t != nullptr && forward != 0.0f;
  const LargeVector<float> fwd =
      streams ? sun_flux_strength(ext, n, L.medium.data(), sun_t, p.albedo, p.mean_cosine, forward)
              : LargeVector<float>();
  const glm::vec3 dir = streams ? -glm::normalize(to_sun) : glm::vec3(0.0f);
  // The flux through the face of medium cell i on side ±1 of axis a, along +a.
  auto face = [&](std::size_t i, const int c[3], int a, int side) {
    const int cc = c[a] + side;
    const bool inside = cc >= 0 && cc < L.dims[a];
    const std::size_t j = side > 0 ? i + L.stride[a] : i - L.stride[a];
    const double ha = L.h[a];
    if (inside && L.medium[j]) {
      const double dh = L.conductance(side > 0 ? i : j, side > 0 ? j : i, a) * ha;
      const double stream = streams ? 0.5 * (static_cast<double>(fwd[i]) + fwd[j]) * dir[a] : 0.0;
      return -dh * (side > 0 ? at(j) - at(i) : at(i) - at(j)) + stream;
    }
    const double d = L.D[i];
    return side * 2.0 * d * at(i) / (ha + 4.0 * d);  // Marshak's leak, outward
  };
  parallel_for(static_cast<std::size_t>(L.Dd), threads, [&](std::size_t zz) {
    const int z = static_cast<int>(zz);
    for (int y = 0; y < L.H; ++y)
      for (int x = 0; x < L.W; ++x) {
        const std::size_t i = (static_cast<std::size_t>(z) * L.H + y) * L.W + x;
        const double f = at(i);
        if (!L.medium[i] || !(f > 0.0)) continue;
        const int c[3] = {x, y, z};
        double r[3], norm = 0.0;
        for (int a = 0; a < 3; ++a) {
          r[a] = 3.0 * 0.5 * (face(i, c, a, -1) + face(i, c, a, 1)) / f;
          norm += r[a] * r[a];
        }
        const double cap = std::sqrt(norm) > 3.0 ? 3.0 / std::sqrt(norm) : 1.0;
        for (int a = 0; a < 3; ++a) out[i * 3 + a] = static_cast<float>(r[a] * cap);
      }
  });
  // Empty cells next to the medium: their medium neighbours' mean (read from the medium cells
  // only, written to the empty ones).
  parallel_for(static_cast<std::size_t>(L.Dd), threads, [&](std::size_t zz) {
    const int z = static_cast<int>(zz);
    for (int y = 0; y < L.H; ++y)
      for (int x = 0; x < L.W; ++x) {
        const std::size_t i = (static_cast<std::size_t>(z) * L.H + y) * L.W + x;
        if (L.medium[i]) continue;
        const int c[3] = {x, y, z};
        float acc[3] = {0.0f, 0.0f, 0.0f};
        int count = 0;
        for (int a = 0; a < 3; ++a)
          for (int side = -1; side <= 1; side += 2) {
            const int cc = c[a] + side;
            if (cc < 0 || cc >= L.dims[a]) continue;
            const std::size_t j = side > 0 ? i + L.stride[a] : i - L.stride[a];
            if (!L.medium[j]) continue;
            for (int k = 0; k < 3; ++k) acc[k] += out[j * 3 + k];
            ++count;
          }
        if (count > 0)
          for (int k = 0; k < 3; ++k) out[i * 3 + k] = acc[k] / static_cast<float>(count);
      }
  });
  return out;
}

}  // namespace cumuli
