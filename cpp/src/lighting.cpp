#include "cumuli/lighting.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

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

// Primitive of the chain cand[first, last) that covers s with the smallest |q| (ties: the
// earlier candidate). If rounding leaves s uncovered, the last candidate starting before s.
inline int attribute_union(const RayContext& r, const Candidate* cand, int first, int last,
                           float s) {
  int best = -1;
  int covering = 0;
  float best_q = INFINITY;
  int fallback = cand[first].primitive;
  for (int c = first; c < last && cand[c].t_in <= s; ++c) {
    fallback = cand[c].primitive;
    if (s > cand[c].t_out) continue;
    ++covering;
    if (covering == 1) {
      best = cand[c].primitive;
      continue;
    }
    if (covering == 2) {  // only now does |q| matter
      best_q = r.cloud.primitives[static_cast<std::size_t>(best)].normalised_distance(
          r.origin + s * r.dir);
    }
    const float q =
        r.cloud.primitives[static_cast<std::size_t>(cand[c].primitive)].normalised_distance(
            r.origin + s * r.dir);
    if (q < best_q) {
      best_q = q;
      best = cand[c].primitive;
    }
  }
  return best >= 0 ? best : fallback;
}

// collect_candidates for many rays sharing one direction (every sun ray of a grid). The per
// primitive parts of the ray–ellipsoid test that depend only on the direction (Rᵀ, d' = Rᵀd/r,
// a = d'·d') are computed once, and the per-ray part runs over the primitives in
// structure-of-arrays form, which the compiler vectorises. The arithmetic is that of
// intersect(Ellipsoid, ...) operation for operation, so the intervals are the same numbers, and
// the clipping and insertion sort are collect_candidates' (t ≥ 0, nothing dropped: the buffer
// holds every primitive).
class SunCandidates {
 public:
  SunCandidates(const CloudShape& cloud, glm::vec3 dir) : n_(cloud.primitives.size()) {
    const float scale = candidate_scale(cloud);
    for (auto* v : {&cx_, &cy_, &cz_, &rx_, &ry_, &rz_, &dx_, &dy_, &dz_, &a_}) v->resize(n_);
    for (auto& row : m_) row.resize(n_);
    for (std::size_t j = 0; j < n_; ++j) {
      Ellipsoid e = cloud.primitives[j];
      e.radii *= scale;
      const glm::mat3 rt = glm::transpose(e.rotation);
      const glm::vec3 d = (rt * dir) / e.radii;
      cx_[j] = e.centre.x, cy_[j] = e.centre.y, cz_[j] = e.centre.z;
      rx_[j] = e.radii.x, ry_[j] = e.radii.y, rz_[j] = e.radii.z;
      dx_[j] = d.x, dy_[j] = d.y, dz_[j] = d.z;
      a_[j] = glm::dot(d, d);
      // (rt * w)[k] = rt[0][k]·w.x + rt[1][k]·w.y + rt[2][k]·w.z, as glm evaluates it.
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) m_[3 * k + c][j] = rt[c][k];
    }
  }

  std::size_t size() const { return n_; }

  // Scratch for one thread: b and the discriminant per primitive.
  struct Scratch {
    std::vector<float> b, disc;
    explicit Scratch(std::size_t n) : b(n), disc(n) {}
  };

  int collect(glm::vec3 origin, Scratch& scratch, Candidate* out) const {
    float* __restrict bs = scratch.b.data();
    float* __restrict ds = scratch.disc.data();
    const float* m0 = m_[0].data(); const float* m1 = m_[1].data(); const float* m2 = m_[2].data();
    const float* m3 = m_[3].data(); const float* m4 = m_[4].data(); const float* m5 = m_[5].data();
    const float* m6 = m_[6].data(); const float* m7 = m_[7].data(); const float* m8 = m_[8].data();
    for (std::size_t j = 0; j < n_; ++j) {
      const float wx = origin.x - cx_[j], wy = origin.y - cy_[j], wz = origin.z - cz_[j];
      const float ox = (m0[j] * wx + m1[j] * wy + m2[j] * wz) / rx_[j];
      const float oy = (m3[j] * wx + m4[j] * wy + m5[j] * wz) / ry_[j];
      const float oz = (m6[j] * wx + m7[j] * wy + m8[j] * wz) / rz_[j];
      const float b = ox * dx_[j] + oy * dy_[j] + oz * dz_[j];
      const float c = (ox * ox + oy * oy + oz * oz) - 1.0f;
      bs[j] = b;
      ds[j] = b * b - a_[j] * c;
    }
    int count = 0;
    for (std::size_t j = 0; j < n_; ++j) {
      if (ds[j] < 0.0f || !(a_[j] > 0.0f)) continue;
      const float sq = std::sqrt(ds[j]);
      const float t0 = std::max((-bs[j] - sq) / a_[j], 0.0f);
      const float t1 = (-bs[j] + sq) / a_[j];
      if (!(t1 > t0)) continue;
      int pos = count++;
      while (pos > 0 && out[pos - 1].t_in > t0) {
        out[pos] = out[pos - 1];
        --pos;
      }
      out[pos] = Candidate{t0, t1, static_cast<int>(j)};
    }
    return count;
  }

 private:
  std::size_t n_;
  std::vector<float> cx_, cy_, cz_, rx_, ry_, rz_, dx_, dy_, dz_, a_;
  std::vector<float> m_[9];
};

// L(v) for the ray in `r` (whose accumulator starts empty) over the sorted candidates.
float light_at(const RayContext& r, LightMethod method, const Candidate* cand, int n,
               float intensity) {
  if (method == LightMethod::Naive) {
    for (int c = 0; c < n; ++c) {
      const int j = cand[c].primitive;
      march_interval(r, cand[c].t_in, cand[c].t_out, [j](float) { return j; });
    }
  } else {
    // Algorithm 2: merge the sorted intervals into their union, march each piece once.
    int c = 0;
    while (c < n) {
      const int first = c;
      float end = cand[c].t_out;
      for (++c; c < n && cand[c].t_in <= end; ++c) end = std::max(end, cand[c].t_out);
      const int last = c;
      if (last - first == 1) {
        const int j = cand[first].primitive;
        march_interval(r, cand[first].t_in, end, [j](float) { return j; });
      } else {
        march_interval(
            r, cand[first].t_in, end,
            [&](float s) { return attribute_union(r, cand, first, last, s); });
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
  const float scale = candidate_scale(cloud);
  Box b{glm::vec3(INFINITY), glm::vec3(-INFINITY)};
  for (Ellipsoid e : cloud.primitives) {
    e.radii *= scale;
    glm::vec3 lo, hi;
    e.bounds(lo, hi);
    b.lo = glm::min(b.lo, lo);
    b.hi = glm::max(b.hi, hi);
  }
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
    for (std::size_t row = b; row < e; ++row) {
      const int z = static_cast<int>(row / ry), y = static_cast<int>(row % ry);
      for (int x = 0; x < rx; ++x) {
        const glm::vec3 v = box.lo + (glm::vec3(x, y, z) + 0.5f) * cell;
        const int n = collector.collect(v, scratch, cand.data());
        Accum acc;
        const RayContext r{cloud, density, v, s.sun_dir, s.step, s.extinction, scatter, queue, acc};
        const std::size_t idx = row * rx + x;
        light[idx] = light_at(r, s.method, cand.data(), n, s.intensity);
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
