#include "cumuli/light/ndt.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include "cumuli/candidates.hpp"
#include "cumuli/parallel.hpp"

namespace cumuli {

namespace {

constexpr float kPi = 3.14159265358979323846f;

// floor(x) for |x| < 2²² with integer arithmetic that vectorises (see noise.cpp's floor_small).
inline float floor_small_light(float x) {
  const int t = static_cast<int>(x);
  return static_cast<float>(t - static_cast<int>(static_cast<float>(t) > x));
}

// Running sums of eq. (7) along one ray.
struct Accum {
  float transmittance = 1.0f;  // T of the samples marched so far (T_{i−1} before sample i)
  float scatter = 0.0f;        // Σ C · (ℓ_i/Δ) · T_{i−1}
  std::uint32_t samples = 0;
};

// Samples waiting for their densities. Queuing them lets fBm run on a block of points
// (Noise::fbm_many on the calling thread, whose index arithmetic is vectorised); they are then
// folded into the sums in march order, so the result is the same as evaluating them one by one.
// Fixed size: nothing is allocated per voxel.
struct SampleQueue {
  static constexpr int kSize = 64;
  float xyz[3 * kSize], len[kSize], rho[kSize];
  int primitive[kSize];
  int n = 0;
};

struct RayContext {
  const CloudShape& cloud;
  const DensitySource& density;
  glm::vec3 origin;
  glm::vec3 dir;
  float step;
  float extinction;
  float scatter;  // C
  SampleQueue& queue;
  Accum& acc;
};

// Densities of the queued samples, then eq. (7)'s sums over them in order.
inline void flush(const RayContext& r) {
  SampleQueue& q = r.queue;
  if (q.n == 0) return;
  if (r.density.constant >= 0.0f) {
    for (int i = 0; i < q.n; ++i) q.rho[i] = r.density.constant;
  } else {
    const auto n = static_cast<std::size_t>(q.n);
    r.density.noise->fbm_many(noise_points(r.cloud, q.xyz, n), n, q.rho, r.density.fbm, 1);
  }
  // The fBm value goes through DensitySource's constant hook, so cloud_density (eq. 2's
  // gating, or eqs. 19–21) sees exactly the number it would have computed itself.
  DensitySource known;
  for (int i = 0; i < q.n; ++i) {
    known.constant = q.rho[i];
    const DensitySample d =
        cloud_density(r.cloud, q.primitive[i],
                      glm::vec3(q.xyz[3 * i], q.xyz[3 * i + 1], q.xyz[3 * i + 2]), known);
    if (d.rho > 0.0f) {
      r.acc.scatter += r.scatter * (q.len[i] / r.step) * r.acc.transmittance;
      r.acc.transmittance *= std::exp(-r.extinction * d.rho * q.len[i]);
    }
  }
  r.acc.samples += static_cast<std::uint32_t>(q.n);
  q.n = 0;
}

// One sample: segment of length `len` with midpoint `s`, attributed to primitive j.
inline void take_sample(const RayContext& r, int j, float s, float len) {
  const glm::vec3 p = r.origin + s * r.dir;
  SampleQueue& q = r.queue;
  q.xyz[3 * q.n] = p.x, q.xyz[3 * q.n + 1] = p.y, q.xyz[3 * q.n + 2] = p.z;
  q.len[q.n] = len;
  q.primitive[q.n] = j;
  if (++q.n == SampleQueue::kSize) flush(r);
}

// The k-th segment of [a, b] is [a + kΔ, min(a + (k+1)Δ, b)]; positions are computed from k, not
// accumulated, so long intervals do not drift.
template <class Attribute>
inline void march_interval(const RayContext& r, float a, float b, Attribute&& attribute) {
  for (int k = 0;; ++k) {
    const float t0 = a + static_cast<float>(k) * r.step;
    if (!(t0 < b)) break;
    const float t1 = std::min(a + static_cast<float>(k + 1) * r.step, b);
    const float s = 0.5f * (t0 + t1);
    take_sample(r, attribute(s), s, t1 - t0);
  }
}

// collect_candidates for many rays sharing one direction (every sun ray of a grid).
//
// Culling: all rays are parallel to d, so a ray meets primitive j only if its origin, projected
// on the plane ⊥ d, lies within j's projected bounding disc (radius = largest grown radius). The
// discs are binned on a 2D grid of that plane once per call; a ray tests only the primitives
// listed in its bin (in increasing j). The bins are conservative (discs inflated by a relative
// margin far above float rounding), so no hit is lost.
//
// Exact test: the parts of the ray–ellipsoid test that depend only on the direction
// (Rᵀ, d' = Rᵀd/r, a = d'·d') are computed once per primitive; the per-ray part is the
// arithmetic of intersect(Ellipsoid, ...) operation for operation, so the intervals are the same
// numbers, and clipping (t ≥ 0) and the insertion sort (primitives visited in increasing j) are
// collect_candidates', with nothing dropped: the buffer holds every primitive.
class SunCandidates {
 public:
  static constexpr int kMaxBins = 128;  // per axis of the projected plane

  SunCandidates(const CloudShape& cloud, glm::vec3 dir) : n_(cloud.primitives.size()) {
    const float scale = candidate_scale(cloud);
    prim_.resize(n_);
    a_.resize(n_);
    std::vector<float> pu(n_), pw(n_), pr(n_);
    // An orthonormal basis (e1, e2) of the plane ⊥ dir.
    const glm::vec3 d = glm::normalize(dir);
    const glm::vec3 helper = std::fabs(d.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    e1_ = glm::normalize(glm::cross(d, helper));
    e2_ = glm::cross(d, e1_);
    dir_ = d;
    float lo_u = INFINITY, lo_w = INFINITY, hi_u = -INFINITY, hi_w = -INFINITY, sum_r = 0.0f;
    for (std::size_t j = 0; j < n_; ++j) {
      Ellipsoid e = cloud.primitives[j];
      e.radii *= scale;
      Prim& p = prim_[j];
      p.centre = e.centre;
      p.radii = e.radii;
      p.rt = glm::transpose(e.rotation);
      p.d = (p.rt * dir) / e.radii;
      a_[j] = glm::dot(p.d, p.d);
      const float r = std::max(e.radii.x, std::max(e.radii.y, e.radii.z));
      pu[j] = glm::dot(e.centre, e1_);
      pw[j] = glm::dot(e.centre, e2_);
      // Margin: relative 1e-4 of the radius and of the coordinates' magnitude.
      pr[j] = r * 1.0001f + 1e-4f * (std::fabs(pu[j]) + std::fabs(pw[j])) + 1e-6f;
      lo_u = std::min(lo_u, pu[j] - pr[j]), hi_u = std::max(hi_u, pu[j] + pr[j]);
      lo_w = std::min(lo_w, pw[j] - pr[j]), hi_w = std::max(hi_w, pw[j] + pr[j]);
      sum_r += pr[j];
    }
    // Bins about half a mean disc radius wide (lists close to the discs that really cover a
    // bin, few copies per disc), at most kMaxBins per axis.
    const float mean_r = n_ ? sum_r / static_cast<float>(n_) : 1.0f;
    const auto bins_for = [&](float extent) {
      const float want = std::ceil(2.0f * extent / std::max(mean_r, 1e-12f));
      return static_cast<int>(std::min(std::max(want, 1.0f), static_cast<float>(kMaxBins)));
    };
    nu_ = bins_for(hi_u - lo_u);
    nw_ = bins_for(hi_w - lo_w);
    lo_u_ = lo_u, lo_w_ = lo_w;
    // Big discs (metaballs grow by √N) can cover many bins each: coarsen the bins until the
    // lists hold at most max(8N, 2²⁰) entries, so memory stays proportional to the cloud.
    const std::size_t max_entries = std::max<std::size_t>(8 * n_, std::size_t{1} << 20);
    for (;;) {
      inv_u_ = static_cast<float>(nu_) / std::max(hi_u - lo_u, 1e-30f);
      inv_w_ = static_cast<float>(nw_) / std::max(hi_w - lo_w, 1e-30f);
      std::size_t entries = 0;
      for (std::size_t j = 0; j < n_; ++j) {
        const auto cu = static_cast<std::size_t>(bin(pu[j] + pr[j] - lo_u_, inv_u_, nu_) -
                                                 bin(pu[j] - pr[j] - lo_u_, inv_u_, nu_) + 1);
        const auto cw = static_cast<std::size_t>(bin(pw[j] + pr[j] - lo_w_, inv_w_, nw_) -
                                                 bin(pw[j] - pr[j] - lo_w_, inv_w_, nw_) + 1);
        entries += cu * cw;
      }
      if (entries <= max_entries || (nu_ == 1 && nw_ == 1)) break;
      nu_ = std::max(1, nu_ / 2), nw_ = std::max(1, nw_ / 2);
    }
    // Counting pass, then fill (CSR layout), primitives in increasing j within each bin.
    std::vector<int> count(static_cast<std::size_t>(nu_) * nw_ + 1, 0);
    const auto range = [&](std::size_t j, int& u0, int& u1, int& w0, int& w1) {
      u0 = bin(pu[j] - pr[j] - lo_u_, inv_u_, nu_), u1 = bin(pu[j] + pr[j] - lo_u_, inv_u_, nu_);
      w0 = bin(pw[j] - pr[j] - lo_w_, inv_w_, nw_), w1 = bin(pw[j] + pr[j] - lo_w_, inv_w_, nw_);
    };
    for (std::size_t j = 0; j < n_; ++j) {
      int u0, u1, w0, w1;
      range(j, u0, u1, w0, w1);
      for (int w = w0; w <= w1; ++w)
        for (int u = u0; u <= u1; ++u) ++count[static_cast<std::size_t>(w) * nu_ + u + 1];
    }
    for (std::size_t i = 1; i < count.size(); ++i) count[i] += count[i - 1];
    start_ = count;
    list_.resize(static_cast<std::size_t>(count.back()));
    for (std::size_t j = 0; j < n_; ++j) {
      int u0, u1, w0, w1;
      range(j, u0, u1, w0, w1);
      for (int w = w0; w <= w1; ++w)
        for (int u = u0; u <= u1; ++u)
          list_[static_cast<std::size_t>(count[static_cast<std::size_t>(w) * nu_ + u]++)] =
              Entry{pu[j], pw[j], pr[j] * pr[j], glm::dot(cloud.primitives[j].centre, d) + pr[j],
                    static_cast<int>(j)};
    }
  }

  std::size_t size() const { return n_; }
  const float* a() const { return a_.data(); }

  // Per-thread results of the last collect(), per primitive j (in its grown unit-sphere frame):
  // b = o'·d', oo = |o'|²; with a = d'·d', |q_j(s)|² = oo + 2bs + as². Valid for candidates.
  struct Scratch {
    std::vector<float> b, oo;
    explicit Scratch(std::size_t n) : b(n), oo(n) {}
  };

  int collect(glm::vec3 origin, Scratch& scratch, Candidate* out) const {
    const float u_abs = glm::dot(origin, e1_), w_abs = glm::dot(origin, e2_);
    const float u = u_abs - lo_u_, w = w_abs - lo_w_;
    if (!(u >= 0.0f && w >= 0.0f)) return 0;
    const int bu = static_cast<int>(u * inv_u_), bw = static_cast<int>(w * inv_w_);
    if (bu >= nu_ + 1 || bw >= nw_ + 1) return 0;  // beyond every disc
    const std::size_t cell = static_cast<std::size_t>(std::min(bw, nw_ - 1)) * nu_ +
                             static_cast<std::size_t>(std::min(bu, nu_ - 1));
    const float h = glm::dot(origin, dir_);
    int count = 0;
    for (int k = start_[cell]; k < start_[cell + 1]; ++k) {
      const Entry& en = list_[static_cast<std::size_t>(k)];
      // Cheap conservative rejections: the whole primitive behind the origin along the ray, or
      // the origin outside its projected disc. Either way the exact test would find no t > 0.
      if (h > en.h_max) continue;
      const float du = u_abs - en.u, dw = w_abs - en.w;
      if (du * du + dw * dw > en.r2) continue;
      const int j = en.j;
      const Prim& p = prim_[static_cast<std::size_t>(j)];
      const float a = a_[static_cast<std::size_t>(j)];
      // intersect(Ellipsoid, ...): o = (Rᵀ(origin − c)) / r, b = o·d, c = o·o − 1.
      const glm::vec3 o = (p.rt * (origin - p.centre)) / p.radii;
      if (!(a > 0.0f)) continue;
      const float b = glm::dot(o, p.d);
      const float oo = glm::dot(o, o);
      const float c = oo - 1.0f;
      const float disc = b * b - a * c;
      if (disc < 0.0f) continue;
      const float sq = std::sqrt(disc);
      const float t0 = std::max((-b - sq) / a, 0.0f);
      const float t1 = (-b + sq) / a;
      if (!(t1 > t0)) continue;
      scratch.b[static_cast<std::size_t>(j)] = b;
      scratch.oo[static_cast<std::size_t>(j)] = oo;
      int pos = count++;
      while (pos > 0 && out[pos - 1].t_in > t0) {
        out[pos] = out[pos - 1];
        --pos;
      }
      out[pos] = Candidate{t0, t1, j};
    }
    return count;
  }

 private:
  struct Prim {
    glm::vec3 centre, radii, d;
    glm::mat3 rt;
  };

  // Bin of offset x (≥ 0 up to rounding) at `inv` bins per unit, clamped to [0, n − 1].
  static int bin(float x, float inv, int n) {
    const float f = std::floor(x * inv);
    return static_cast<int>(std::min(std::max(f, 0.0f), static_cast<float>(n - 1)));
  }

  std::size_t n_;
  std::vector<Prim> prim_;
  std::vector<float> a_;
  glm::vec3 e1_{}, e2_{};
  float lo_u_ = 0, lo_w_ = 0, inv_u_ = 1, inv_w_ = 1;
  int nu_ = 1, nw_ = 1;
  // A bin's entry: projected centre (u, w), squared disc radius, the largest ray coordinate
  // dot(p, d) of the primitive's bounding sphere, and the primitive.
  struct Entry {
    float u, w, r2, h_max;
    int j;
  };
  glm::vec3 dir_{};
  std::vector<int> start_;
  std::vector<Entry> list_;
};

// Per-thread storage for UnionAttribution's active candidates, structure of arrays.
struct ActiveBuffers {
  std::vector<int> primitive;
  std::vector<float> oo, b2, a, t_out;
  explicit ActiveBuffers(std::size_t n) : primitive(n), oo(n), b2(n), a(n), t_out(n) {}
};

// Attribution of union samples: union_owner's rule (candidates.hpp; RENDER_CONTRACT
// march="union"), evaluated incrementally for speed. Samples come in increasing s,
// so the covering set is kept as a list of "active" candidates (entered: t_in ≤ s; dropped for
// good once t_out < s), and |q_j(s)|² is the quadratic oo + 2bs + as² from the candidate test,
// three multiply-adds instead of a transform. A near-tie decided differently by rounding picks a
// primitive with the same |q| to float precision, hence the same γ of eq. (2).
class UnionAttribution {
 public:
  UnionAttribution(const Candidate* cand, int first, int last, ActiveBuffers& buf, const float* a,
                   const SunCandidates::Scratch& sc)
      : cand_(cand),
        next_(first),
        last_(last),
        buf_(buf),
        a_(a),
        sc_(sc),
        fallback_(cand[first].primitive) {}

  int operator()(float s) {
    while (next_ < last_ && cand_[next_].t_in <= s) enter(next_++);
    if (s > min_t_out_) drop_ended(s);  // only when some candidate has ended
    if (count_ <= 1) return count_ == 1 ? buf_.primitive[0] : fallback_;
    // The first smallest |q|² of the active candidates. Branch-free selects: which candidate
    // is nearest changes unpredictably from sample to sample, and mispredicted branches cost
    // more than the arithmetic.
    const float* __restrict oo = buf_.oo.data();
    const float* __restrict b2 = buf_.b2.data();
    const float* __restrict a = buf_.a.data();
    float best_q2 = oo[0] + s * (b2[0] + s * a[0]);
    int best = 0;
    for (int i = 1; i < count_; ++i) {
      const float q2 = oo[i] + s * (b2[i] + s * a[i]);
      const bool nearer = q2 < best_q2;
      best_q2 = nearer ? q2 : best_q2;
      best = nearer ? i : best;
    }
    return buf_.primitive[static_cast<std::size_t>(best)];
  }

 private:
  void enter(int c) {
    const int j = cand_[c].primitive;
    const auto js = static_cast<std::size_t>(j);
    const auto k = static_cast<std::size_t>(count_++);
    buf_.primitive[k] = j;
    buf_.oo[k] = sc_.oo[js];
    buf_.b2[k] = 2.0f * sc_.b[js];
    buf_.a[k] = a_[js];
    buf_.t_out[k] = cand_[c].t_out;
    min_t_out_ = std::min(min_t_out_, cand_[c].t_out);
  }

  // Drops the candidates with t_out < s for good (samples only move forward), keeping order.
  void drop_ended(float s) {
    int kept = 0;
    min_t_out_ = INFINITY;
    for (int i = 0; i < count_; ++i) {
      if (buf_.t_out[static_cast<std::size_t>(i)] < s) continue;
      const auto from = static_cast<std::size_t>(i), to = static_cast<std::size_t>(kept++);
      buf_.primitive[to] = buf_.primitive[from];
      buf_.oo[to] = buf_.oo[from];
      buf_.b2[to] = buf_.b2[from];
      buf_.a[to] = buf_.a[from];
      buf_.t_out[to] = buf_.t_out[from];
      min_t_out_ = std::min(min_t_out_, buf_.t_out[to]);
    }
    // Rounding can leave s just past every interval: keep the last one entered.
    if (kept == 0 && count_ > 0) fallback_ = buf_.primitive[static_cast<std::size_t>(count_ - 1)];
    count_ = kept;
  }

  const Candidate* cand_;
  int next_, last_;
  ActiveBuffers& buf_;
  const float* a_;
  const SunCandidates::Scratch& sc_;
  int fallback_;
  int count_ = 0;
  float min_t_out_ = INFINITY;
};

// L(v) for the ray in `r` (whose accumulator starts empty) over the sorted candidates.
float light_at(const RayContext& r, LightMethod method, const Candidate* cand, int n,
               float intensity, const SunCandidates& collector,
               const SunCandidates::Scratch& scratch, ActiveBuffers& active) {
  if (method == LightMethod::Naive) {
    for (int c = 0; c < n; ++c) {
      const int j = cand[c].primitive;
      march_interval(r, cand[c].t_in, cand[c].t_out, [j](float) { return j; });
    }
  } else {
    // Algorithm 2: merge the sorted intervals into their union, march each piece once.
    const bool attribute = r.cloud.density.model == DensityModel::Spheroid;
    int c = 0;
    while (c < n) {
      const int first = c;
      float end = cand[c].t_out;
      for (++c; c < n && cand[c].t_in <= end; ++c) end = std::max(end, cand[c].t_out);
      const int last = c;
      if (last - first == 1 || !attribute) {  // metaball density ignores the primitive
        const int j = cand[first].primitive;
        march_interval(r, cand[first].t_in, end, [j](float) { return j; });
      } else {
        march_interval(r, cand[first].t_in, end,
                       UnionAttribution(cand, first, last, active, collector.a(), scratch));
      }
    }
  }
  flush(r);
  return r.acc.scatter + intensity * r.acc.transmittance;
}

// --- method Shared: each sun-parallel line marched once, resampled into the grid -------------
//
// Geometry. Let a be the grid axis the sun line crosses fastest in voxel units (largest
// |d_a| / cell_a) and b, c the other two. Moving one voxel layer along a, a sun line moves
// s_b = (d_b / d_a)·(cell_a / cell_b) voxels along b (|s_b| ≤ 1) and s_c along c. Line (l_b, l_c)
// is the one whose voxel coordinates on layer j are (l_b + s_b·j, l_c + s_c·j): the lines form a
// grid sheared with the sun, one line per voxel column of a layer, and the voxel centres of layer
// j lie between four of them at the fractions frac(i_b − s_b·j), frac(i_c − s_c·j).
//
// March. Along a line the layers are λ = cell_a / |d_a| apart. The line is cut into segments of
// Δ' = λ / n, n = max(1, round(λ / Δ)), so every layer crossing is a segment boundary; within the
// union of the line's candidate intervals each segment (truncated at an interval's end, as in the
// per-voxel march) gives one sample at its midpoint, attributed by NDT's rule and gated by eq. (2)
// (|q| from the candidate test's quadratic, exp by a polynomial good to 2e-7). Walking
// back from the sun, S = I₀ beyond the last sample and, per sample i of length ℓᵢ,
//   S ← C · (ℓᵢ/Δ) · [ρᵢ > 0] + exp(−A·ρᵢ·ℓᵢ) · S,
// which is eq. (7)'s L(v) for a ray starting at the near end of sample i; S read at a layer
// crossing is L of that point of the line. A voxel's L is the bilinear blend of the four lines
// around it on its layer.
//
// Difference from the per-voxel definition: the voxel's value is read from lines up to a voxel
// away sideways (an interpolation of the fBm-detailed field across a voxel), and the samples sit
// on a grid of step Δ' ≤ 1.5·Δ anchored at the layers instead of at each interval's entry. Each
// sample is marched once for all the voxels behind it instead of once per voxel.
// exp(x) for x ≤ 0 in plain float arithmetic that the compiler vectorises (libm's expf is a
// call per value): x = k·ln2 + r with |r| ≤ ln2/2, exp(r) by its degree-6 Taylor polynomial
// (relative error < 2e-7), times 2^k built from the exponent bits; 0 below −87.
inline float exp_nonpositive(float x) {
  const float xc = std::max(x, -87.0f);
  const float kf = floor_small_light(xc * 1.44269504f + 0.5f);
  const float r = (xc - kf * 0.693359375f) - kf * -2.12194440e-4f;
  const float poly =
      1.0f +
      r * (1.0f + r * (0.5f + r * (1.0f / 6.0f + r * (1.0f / 24.0f +
                                                      r * (1.0f / 120.0f + r * (1.0f / 720.0f))))));
  const std::int32_t bits = (static_cast<std::int32_t>(kf) + 127) << 23;
  float scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return poly * scale * static_cast<float>(x >= -87.0f);  // a product, not a branch
}

// The per-sample arithmetic of a shared line as plain loops over its arrays, compiled for the
// baseline and (GCC on glibc) for AVX2 / AVX-512 too, picked at load time: the same IEEE
// operations in every clone (no FMA), so the same bits.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__GLIBC__)
#define CUMULI_VEC_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define CUMULI_VEC_CLONES
#endif

// eq. (2): a sample is cloud where |q| ≤ 1 and ρ < γ = exp(−|q| / ((1 − κ) + 2κρ)); ρ ← 0 where
// it is not. |q|² comes from the candidate test's quadratic.
CUMULI_VEC_CLONES void spheroid_gate(const float* q2, float* rho, std::size_t n, float kappa) {
  for (std::size_t i = 0; i < n; ++i) {
    const float q = std::sqrt(std::max(q2[i], 0.0f));
    const float gamma = exp_nonpositive(-q / ((1.0f - kappa) + 2.0f * kappa * rho[i]));
    rho[i] = ((q2[i] <= 1.0f) & (rho[i] < gamma)) ? rho[i] : 0.0f;
  }
}

// att = exp(−A·ρ·ℓ) per sample, and its scattering term C·(ℓ/Δ) where ρ > 0, else 0 (then att
// is exactly 1, so the sweep's S ← term + att·S leaves S unchanged without a branch).
CUMULI_VEC_CLONES void attenuation(const float* rho, const float* len, float* att, float* term,
                                   std::size_t n, float extinction, float scatter_per_length) {
  for (std::size_t i = 0; i < n; ++i) {
    att[i] = exp_nonpositive(-extinction * rho[i] * len[i]);
    term[i] = rho[i] > 0.0f ? scatter_per_length * len[i] : 0.0f;
  }
}

// |q|² = oo + s·(2b + s·a) of primitive j at the samples [i0, i1) (the candidate test's
// quadratic); where it is smaller than q2s (or always, without keep_smaller) it and j are stored.
CUMULI_VEC_CLONES void nearest_quadratic(const float* mid, float* q2s, int* prim, std::size_t i0,
                                         std::size_t i1, float oo, float b2, float qa, int j,
                                         bool keep_smaller) {
  for (std::size_t i = i0; i < i1; ++i) {
    const float q2 = oo + mid[i] * (b2 + mid[i] * qa);
    const bool take = !keep_smaller || q2 < q2s[i];
    q2s[i] = take ? q2 : q2s[i];
    prim[i] = take ? j : prim[i];
  }
}

// The line loop's buffers (candidates, the candidate test's scratch, and per sample of the
// current line: position, t of its midpoint, length, far end, |q|² of its primitive for eq. 2's
// gate, primitive, density, attenuation). They only grow.
struct LineBuffers {
  static constexpr std::size_t kKeepSamples = std::size_t{1} << 16;  // ≈ 2.3 MB kept at most

  std::vector<Candidate> cand;
  SunCandidates::Scratch scratch{0};
  std::vector<float> xyz, mid, len, t1s, q2s, rho, att, term;
  std::vector<int> prim;

  void reserve(std::size_t primitives, std::size_t collector_size) {
    if (cand.size() < primitives) cand.resize(primitives);
    if (scratch.b.size() < collector_size) {
      scratch.b.resize(collector_size);
      scratch.oo.resize(collector_size);
    }
  }
};

LightStats light_grid_shared(const CloudShape& cloud, const DensitySource& density,
                             const LightSettings& s, const Box& box, const SunCandidates& collector,
                             float* light, std::uint32_t* samples_out) {
  const int res[3] = {s.resolution[0], s.resolution[1], s.resolution[2]};
  const glm::vec3 cell = (box.hi - box.lo) / glm::vec3(res[0], res[1], res[2]);
  const glm::vec3 d = s.sun_dir;
  int a = 0;
  for (int k = 1; k < 3; ++k)
    if (std::fabs(d[k]) / cell[k] > std::fabs(d[a]) / cell[a]) a = k;
  const int b = (a + 1) % 3, c = (a + 2) % 3;
  const int ra = res[a], rb = res[b], rc = res[c];
  const float sb = (d[b] / d[a]) * (cell[a] / cell[b]);
  const float sc = (d[c] / d[a]) * (cell[a] / cell[c]);
  const int toward = d[a] > 0.0f ? 1 : -1;  // layer index step towards the sun
  const float lambda = cell[a] / std::fabs(d[a]);
  const int per_layer =
      std::max(1, static_cast<int>(std::lround(static_cast<double>(lambda) / s.step)));
  const float sub = lambda / static_cast<float>(per_layer);  // Δ'

  // Lines used on layer j along b: floor(−s_b·j) .. floor(R_b − 1 − s_b·j) + 1 (and along c).
  std::vector<int> lob(ra), hib(ra), loc(ra), hic(ra);
  for (int j = 0; j < ra; ++j) {
    lob[j] = static_cast<int>(std::floor(-sb * j));
    hib[j] = static_cast<int>(std::floor(static_cast<float>(rb - 1) - sb * j)) + 1;
    loc[j] = static_cast<int>(std::floor(-sc * j));
    hic[j] = static_cast<int>(std::floor(static_cast<float>(rc - 1) - sc * j)) + 1;
  }
  const int b0 = *std::min_element(lob.begin(), lob.end());
  const int b1 = *std::max_element(hib.begin(), hib.end());
  const int c0 = *std::min_element(loc.begin(), loc.end());
  const int c1 = *std::max_element(hic.begin(), hic.end());
  const int nb = b1 - b0 + 1, nc = c1 - c0 + 1;
  const std::size_t lines = static_cast<std::size_t>(nb) * nc;
  // The layers each line serves form one interval [j_lo, j_hi] (empty: j_hi < j_lo). S of every
  // line at every layer it serves, packed line by line from offset[line] (about one value per
  // voxel, whatever the shear); `beyond`: the samples each value depends on.
  // The layers of line (l_b, l_c) are those of its b index that are also those of its c index:
  // each is an interval (the bounds move monotonically with j), found once per index.
  const auto layers_of = [ra](int index, const std::vector<int>& lo, const std::vector<int>& hi,
                              int& first, int& last) {
    first = ra, last = -1;
    for (int j = 0; j < ra; ++j) {
      if (index >= lo[j] && index <= hi[j]) {
        first = std::min(first, j);
        last = j;
      }
    }
  };
  std::vector<int> jb_lo(nb), jb_hi(nb), jc_lo(nc), jc_hi(nc);
  for (int k = 0; k < nb; ++k) layers_of(b0 + k, lob, hib, jb_lo[k], jb_hi[k]);
  for (int k = 0; k < nc; ++k) layers_of(c0 + k, loc, hic, jc_lo[k], jc_hi[k]);
  std::vector<int> served_lo(lines), served_hi(lines);
  std::vector<std::size_t> offset(lines + 1, 0);
  for (std::size_t line = 0; line < lines; ++line) {
    const std::size_t kb = line / nc, kc = line % nc;
    served_lo[line] = std::max(jb_lo[kb], jc_lo[kc]);
    served_hi[line] = std::min(jb_hi[kb], jc_hi[kc]);
    offset[line + 1] =
        offset[line] + static_cast<std::size_t>(std::max(0, served_hi[line] - served_lo[line] + 1));
  }
  std::vector<float> S(offset[lines], 0.0f);
  std::vector<std::uint32_t> beyond(samples_out ? offset[lines] : 0, 0);
  const auto at = [&](std::size_t line, int j) {
    return offset[line] + static_cast<std::size_t>(j - served_lo[line]);
  };

  const float scatter = s.scatter_constant();
  const float scatter_per_length = scatter / s.step;
  const int capacity = static_cast<int>(cloud.primitives.size());
  const bool spheroid = cloud.density.model == DensityModel::Spheroid;
  const float kappa = cloud.density.kappa;
  // Samples marched, summed per chunk (an integer sum: the same total in any order).
  std::atomic<std::uint64_t> samples_total{0};

  parallel_chunks(lines, s.threads, [&](std::size_t first, std::size_t last) {
    // This thread's buffers, kept between its chunks and between calls: a small grid's lines
    // take microseconds each, so allocating them per chunk was a measurable share.
    thread_local LineBuffers buffers;
    buffers.reserve(static_cast<std::size_t>(capacity), collector.size());
    std::vector<Candidate>& cand = buffers.cand;
    SunCandidates::Scratch& scratch = buffers.scratch;
    std::vector<float>&xyz = buffers.xyz, &mid = buffers.mid, &len = buffers.len,
    &t1s = buffers.t1s, &q2s = buffers.q2s, &rho = buffers.rho, &att = buffers.att,
    &term = buffers.term;
    std::vector<int>& prim = buffers.prim;
    std::uint64_t chunk_samples = 0;
    for (std::size_t line = first; line < last; ++line) {
      const int lb = b0 + static_cast<int>(line / nc), lc = c0 + static_cast<int>(line % nc);
      const int j_lo = served_lo[line], j_hi = served_hi[line];
      if (j_hi < j_lo) continue;
      const int j_start = toward > 0 ? j_lo : j_hi;  // the served layer farthest from the sun
      glm::vec3 origin;
      origin[a] = box.lo[a] + (static_cast<float>(j_start) + 0.5f) * cell[a];
      origin[b] = box.lo[b] + (static_cast<float>(lb) + sb * j_start + 0.5f) * cell[b];
      origin[c] = box.lo[c] + (static_cast<float>(lc) + sc * j_start + 0.5f) * cell[c];

      // March the union of the candidate intervals on the Δ' grid (NDT's merge and attribution).
      const int n = collector.collect(origin, scratch, cand.data());
      const float* pa = collector.a();
      // At most one sample per Δ' segment of the span plus one per interval end.
      float span = 0.0f;
      for (int k = 0; k < n; ++k) span = std::max(span, cand[k].t_out);
      const std::size_t most =
          static_cast<std::size_t>(span / sub) + 2 * static_cast<std::size_t>(n) + 2;
      if (len.size() < most) {
        xyz.resize(3 * most), mid.resize(most), len.resize(most), t1s.resize(most);
        q2s.resize(most);
        prim.resize(most), rho.resize(most), att.resize(most), term.resize(most);
      }
      std::size_t m = 0;
      int ci = 0;
      while (ci < n) {
        // One piece of the union: candidates [cfirst, ci) overlap into [A, B].
        const int cfirst = ci;
        float B = cand[ci].t_out;
        for (++ci; ci < n && cand[ci].t_in <= B; ++ci) B = std::max(B, cand[ci].t_out);
        const float A = cand[cfirst].t_in;
        const std::size_t m0 = m;
        long long k = static_cast<long long>(std::floor(A / sub));
        while (k > 0 && static_cast<float>(k) * sub > A) --k;
        while (static_cast<float>(k + 1) * sub <= A) ++k;
        const long long k_start = k;  // sample m0 + i lies in segment k_start + i (or next to it)
        for (;; ++k) {
          const float ta = static_cast<float>(k) * sub;
          if (!(ta < B)) break;
          const float t0 = std::max(ta, A);
          const float t1 = std::min(static_cast<float>(k + 1) * sub, B);
          if (!(t1 > t0)) continue;
          mid[m] = 0.5f * (t0 + t1);
          len[m] = t1 - t0;
          t1s[m] = t1;
          ++m;
        }
        // Attribution (union_owner's rule): the covering candidate with the smallest |q|², the
        // first in candidate order on ties, |q|² from the candidate test's quadratic. Candidate
        // by candidate over the samples it covers, so the inner loop is a vector loop.
        const auto quadratic = [&](int j, std::size_t i0, std::size_t i1, bool keep_smaller) {
          const auto js = static_cast<std::size_t>(j);
          nearest_quadratic(mid.data(), q2s.data(), prim.data(), i0, i1, scratch.oo[js],
                            2.0f * scratch.b[js], pa[js], j, keep_smaller);
        };
        if (ci - cfirst == 1 || !spheroid) {
          quadratic(cand[cfirst].primitive, m0, m, false);
        } else {
          std::fill(q2s.begin() + static_cast<std::ptrdiff_t>(m0),
                    q2s.begin() + static_cast<std::ptrdiff_t>(m), INFINITY);
          // Samples are in increasing t, one per Δ' segment: the first sample at or after t
          // (`after`: strictly after t) in [from, m) is found from t's segment index and a step
          // or two along `mid` — what std::lower_bound / upper_bound return, without their
          // mispredicted branches (a tenth of this method's time on the default cumulus).
          const auto first_sample = [&](float t, std::size_t from, bool after) {
            const long long guess = static_cast<long long>(m0) +
                                    static_cast<long long>(floor_small_light(t / sub)) - k_start;
            std::size_t i = static_cast<std::size_t>(
                std::clamp(guess, static_cast<long long>(from), static_cast<long long>(m)));
            const auto before_t = [&](float v) { return after ? v <= t : v < t; };
            while (i > from && !before_t(mid[i - 1])) --i;
            while (i < m && before_t(mid[i])) ++i;
            return i;
          };
          for (int cc = cfirst; cc < ci; ++cc) {
            // Those with t_in ≤ s ≤ t_out are one run.
            const std::size_t i0 = first_sample(cand[cc].t_in, m0, false);
            const std::size_t i1 = first_sample(cand[cc].t_out, i0, true);
            quadratic(cand[cc].primitive, i0, i1, true);
          }
          // Rounding can leave a sample just past every interval: give it the last one that
          // ended before it.
          for (std::size_t i = m0; i < m; ++i) {
            if (q2s[i] != INFINITY) continue;
            int owner = cand[cfirst].primitive;
            for (int cc = cfirst; cc < ci; ++cc)
              if (cand[cc].t_out < mid[i]) owner = cand[cc].primitive;
            quadratic(owner, i, i + 1, false);
          }
        }
      }
      for (std::size_t i = 0; i < m; ++i) {
        xyz[3 * i] = origin.x + mid[i] * d.x;
        xyz[3 * i + 1] = origin.y + mid[i] * d.y;
        xyz[3 * i + 2] = origin.z + mid[i] * d.z;
      }
      if (density.constant >= 0.0f) {
        std::fill(rho.begin(), rho.begin() + static_cast<std::ptrdiff_t>(m), density.constant);
      } else if (m > 0) {
        density.noise->fbm_many(noise_points(cloud, xyz.data(), m), m, rho.data(), density.fbm, 1);
      }
      if (spheroid) {
        spheroid_gate(q2s.data(), rho.data(), m, kappa);
      } else {
        DensitySource known;
        for (std::size_t i = 0; i < m; ++i) {
          known.constant = rho[i];
          rho[i] =
              metaball_density(cloud, glm::vec3(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]), known)
                  .rho;
        }
      }
      attenuation(rho.data(), len.data(), att.data(), term.data(), m, s.extinction,
                  scatter_per_length);
      // Walk back from the sun; the served layers in order of decreasing t.
      float Sv = s.intensity;
      std::size_t i = m;
      const int j_far = toward > 0 ? j_hi : j_lo;
      for (int j = j_far;; j -= toward) {
        const long long k_layer = static_cast<long long>(std::abs(j - j_start)) * per_layer;
        const float t_layer = static_cast<float>(k_layer) * sub;
        while (i > 0 && t1s[i - 1] > t_layer) {
          --i;
          Sv = term[i] + att[i] * Sv;
        }
        S[at(line, j)] = Sv;
        if (samples_out) beyond[at(line, j)] = static_cast<std::uint32_t>(m - i);
        if (j == j_start) break;
      }
      chunk_samples += m;
    }
    samples_total += chunk_samples;
    // Lines of hundreds of thousands of samples (a tiny step) are slow anyway: do not keep their
    // buffers (tens of MB) alive in this thread after the call.
    if (buffers.mid.size() > LineBuffers::kKeepSamples) buffers = LineBuffers{};
  });

  // Resample: each voxel blends the four lines around it on its layer (a few ns a voxel; layers
  // are split between threads, whose pool makes even a small grid's split cheap).
  const std::size_t stride[3] = {1, static_cast<std::size_t>(res[0]),
                                 static_cast<std::size_t>(res[0]) * res[1]};  // [z][y][x]
  const std::size_t nc_lines = static_cast<std::size_t>(nc);
  parallel_chunks(static_cast<std::size_t>(ra), s.threads, [&](std::size_t j0, std::size_t j1) {
    // Per layer: S (and `beyond`) of the lines serving it, indexed by line, so that a voxel
    // reads its four lines with plain loads; the c-axis index and weight of each voxel column.
    std::vector<float> layer_S(lines);
    std::vector<std::uint32_t> layer_beyond(samples_out ? lines : 0);
    std::vector<std::size_t> kc(static_cast<std::size_t>(rc));
    std::vector<float> wcs(static_cast<std::size_t>(rc));
    float* const out = light;  // written only here: the reads below come from other arrays
    // `values` (S or `beyond`, packed line by line) of the lines serving layer jj, by line.
    const auto by_line = [&](const auto& values, auto& layer, std::size_t jj) {
      const int j = static_cast<int>(jj);
      for (int lb = lob[jj]; lb <= hib[jj]; ++lb) {
        const std::size_t row = static_cast<std::size_t>(lb - b0) * nc_lines;
        for (int lc = loc[jj]; lc <= hic[jj]; ++lc) {
          const std::size_t line = row + static_cast<std::size_t>(lc - c0);
          layer[line] = values[at(line, j)];
        }
      }
    };
    for (std::size_t jj = j0; jj < j1; ++jj) {
      const int j = static_cast<int>(jj);
      by_line(S, layer_S, jj);
      for (int ic = 0; ic < rc; ++ic) {
        const float uc = static_cast<float>(ic) - sc * j;
        const float fc_floor = floor_small_light(uc);
        wcs[static_cast<std::size_t>(ic)] = uc - fc_floor;
        kc[static_cast<std::size_t>(ic)] =
            static_cast<std::size_t>(static_cast<int>(fc_floor) - c0);
      }
      const std::size_t* const k_of = kc.data();
      const float* const w_of = wcs.data();
      const std::size_t step_c = stride[c];
      for (int ib = 0; ib < rb; ++ib) {
        const float ub = static_cast<float>(ib) - sb * j;
        const float fb_floor = floor_small_light(ub);
        const float wb = ub - fb_floor;
        const std::size_t kb = static_cast<std::size_t>(static_cast<int>(fb_floor) - b0);
        const float* const row0 = layer_S.data() + kb * nc_lines;  // lines kb; kb + 1 at + nc
        const float* const row1 = row0 + nc_lines;
        float* const dst = out + jj * stride[a] + static_cast<std::size_t>(ib) * stride[b];
        for (std::size_t ic = 0; ic < static_cast<std::size_t>(rc); ++ic) {
          const std::size_t k = k_of[ic];
          const float wc = w_of[ic];
          const float s0 = row0[k] + wc * (row0[k + 1] - row0[k]);
          const float s1 = row1[k] + wc * (row1[k + 1] - row1[k]);
          dst[ic * step_c] = s0 + wb * (s1 - s0);
        }
      }
      if (!samples_out) continue;
      // Samples behind each voxel: those of the line nearest to it.
      by_line(beyond, layer_beyond, jj);
      for (int ib = 0; ib < rb; ++ib) {
        const float ub = static_cast<float>(ib) - sb * j;
        const float fb_floor = floor_small_light(ub);
        const std::size_t kb = static_cast<std::size_t>(static_cast<int>(fb_floor) - b0);
        const std::size_t near_b = kb + (ub - fb_floor < 0.5f ? 0 : 1);
        std::uint32_t* const dst =
            samples_out + jj * stride[a] + static_cast<std::size_t>(ib) * stride[b];
        for (std::size_t ic = 0; ic < static_cast<std::size_t>(rc); ++ic) {
          const std::size_t near = near_b * nc_lines + k_of[ic] + (w_of[ic] < 0.5f ? 0 : 1);
          dst[ic * stride[c]] = layer_beyond[near];
        }
      }
    }
  });
  LightStats stats;
  stats.samples = samples_total.load();
  return stats;
}

}  // namespace

float LightSettings::scatter_constant() const { return 0.5f * solid_angle / (4.0f * kPi); }

void LightSettings::validate(const Box& box) const {
  for (int a = 0; a < 3; ++a) {
    if (resolution[a] < 2 || resolution[a] > kMaxResolution)
      throw std::invalid_argument("resolution must be in [2, " + std::to_string(kMaxResolution) +
                                  "] on every axis, got " + std::to_string(resolution[a]));
  }
  if (!std::isfinite(sun_dir.x) || !std::isfinite(sun_dir.y) || !std::isfinite(sun_dir.z) ||
      !(glm::dot(sun_dir, sun_dir) > 1e-24f))
    throw std::invalid_argument("sun direction must be finite and non-zero");
  if (!std::isfinite(step) || !(step > 0.0f))
    throw std::invalid_argument("step must be a finite positive number");
  if (!std::isfinite(extinction) || extinction < 0.0f)
    throw std::invalid_argument("extinction must be finite and non-negative");
  if (!std::isfinite(solid_angle) || solid_angle < 0.0f || solid_angle > 4.0f * kPi)
    throw std::invalid_argument("solid_angle must be in [0, 4π] steradians");
  if (!std::isfinite(intensity) || intensity < 0.0f)
    throw std::invalid_argument("intensity must be finite and non-negative");
  const double diag = glm::length(glm::dvec3(box.hi - box.lo));
  if (!std::isfinite(diag)) throw std::invalid_argument("cloud box is not finite");
  if (diag / step > kMaxStepsPerRay)
    throw std::invalid_argument("step " + std::to_string(step) +
                                " is too small for the cloud box (" + std::to_string(diag) +
                                " units across): a ray would need more than " +
                                std::to_string(static_cast<long long>(kMaxStepsPerRay)) + " steps");
}

Box light_grid_box(const CloudShape& cloud, const int resolution[3]) {
  Box b = candidate_bounds(cloud);
  // Centres of voxels 0 and R−1 on the faces: lo + 0.5·h = b.lo with h = (b.hi − b.lo)/(R − 1).
  for (int a = 0; a < 3; ++a) {
    const float h = (b.hi[a] - b.lo[a]) / static_cast<float>(std::max(resolution[a] - 1, 1));
    b.lo[a] -= 0.5f * h;
    b.hi[a] += 0.5f * h;
  }
  return b;
}

LightStats compute_light_grid(const CloudShape& cloud, const DensitySource& density,
                              const LightSettings& settings_in, float* light,
                              std::uint32_t* samples) {
  cloud.validate();
  if (density.constant < 0.0f) {
    if (density.noise == nullptr)
      throw std::invalid_argument("a noise is required unless a constant density is given");
    density.fbm.validate();
  } else if (!std::isfinite(density.constant)) {
    throw std::invalid_argument("constant density must be finite");
  }
  LightSettings s = settings_in;
  for (int a = 0; a < 3; ++a)
    if (s.resolution[a] < 2 || s.resolution[a] > LightSettings::kMaxResolution)
      s.validate(Box{});  // throws the resolution message before the box is built
  const Box box = light_grid_box(cloud, s.resolution);
  s.validate(box);
  s.sun_dir = glm::normalize(s.sun_dir);

  const int rx = s.resolution[0], ry = s.resolution[1], rz = s.resolution[2];
  const glm::vec3 cell = (box.hi - box.lo) / glm::vec3(rx, ry, rz);
  const float scatter = s.scatter_constant();
  const int capacity = static_cast<int>(cloud.primitives.size());
  // The timed work starts with the candidate binning, which every method needs (once).
  const auto start = std::chrono::steady_clock::now();
  const SunCandidates collector(cloud, s.sun_dir);
  if (s.method == LightMethod::Shared) {
    LightStats stats = light_grid_shared(cloud, density, s, box, collector, light, samples);
    stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return stats;
  }
  // Samples per row of voxels, summed after the loop (no shared counter between threads).
  std::vector<std::uint64_t> row_samples(static_cast<std::size_t>(rz) * ry, 0);
  parallel_chunks(static_cast<std::size_t>(rz) * ry, s.threads, [&](std::size_t b, std::size_t e) {
    // One candidate buffer per chunk, big enough for every primitive: nothing is dropped and
    // nothing is allocated per voxel.
    std::vector<Candidate> cand(static_cast<std::size_t>(capacity));
    SunCandidates::Scratch scratch(collector.size());
    SampleQueue queue;
    ActiveBuffers active(static_cast<std::size_t>(capacity));
    for (std::size_t row = b; row < e; ++row) {
      const int z = static_cast<int>(row / ry), y = static_cast<int>(row % ry);
      for (int x = 0; x < rx; ++x) {
        const glm::vec3 v = box.lo + (glm::vec3(x, y, z) + 0.5f) * cell;
        const int n = collector.collect(v, scratch, cand.data());
        Accum acc;
        const RayContext r{cloud, density, v, s.sun_dir, s.step, s.extinction, scatter, queue, acc};
        const std::size_t idx = row * rx + x;
        light[idx] = light_at(r, s.method, cand.data(), n, s.intensity, collector, scratch, active);
        if (samples) samples[idx] = acc.samples;
        row_samples[row] += acc.samples;
      }
    }
  });
  LightStats stats;
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const std::uint64_t n : row_samples) stats.samples += n;
  return stats;
}

}  // namespace cumuli
