#include "cumuli/light/ndt.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
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
    r.density.noise->fbm_many(q.xyz, static_cast<std::size_t>(q.n), q.rho, r.density.fbm, 1);
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
  UnionAttribution(const Candidate* cand, int first, int last, ActiveBuffers& buf,
                   const float* a, const SunCandidates::Scratch& sc)
      : cand_(cand), next_(first), last_(last), buf_(buf), a_(a), sc_(sc),
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
    throw std::invalid_argument("step " + std::to_string(step) + " is too small for the cloud box (" +
                                std::to_string(diag) + " units across): a ray would need more than " +
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
  const SunCandidates collector(cloud, s.sun_dir);

  const auto start = std::chrono::steady_clock::now();
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
        light[idx] = light_at(r, s.method, cand.data(), n, s.intensity, collector, scratch,
                              active);
        if (samples) samples[idx] = acc.samples;
        row_samples[row] += acc.samples;
      }
    }
  });
  LightStats stats;
  stats.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (const std::uint64_t n : row_samples) stats.samples += n;
  return stats;
}

}  // namespace cumuli
