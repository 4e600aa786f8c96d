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

struct RayContext {
  const CloudShape& cloud;
  const DensitySource& density;
  glm::vec3 origin;
  glm::vec3 dir;
  float step;
  float extinction;
  float scatter;  // C
};

// One sample: segment of length `len` with midpoint `s`, attributed to primitive j.
inline void take_sample(const RayContext& r, int j, float s, float len, Accum& acc) {
  const glm::vec3 p = r.origin + s * r.dir;
  const DensitySample d = cloud_density(r.cloud, j, p, r.density);
  ++acc.samples;
  if (d.rho > 0.0f) {
    acc.scatter += r.scatter * (len / r.step) * acc.transmittance;
    acc.transmittance *= std::exp(-r.extinction * d.rho * len);
  }
}

// The k-th segment of [a, b] is [a + kΔ, min(a + (k+1)Δ, b)]; positions are computed from k, not
// accumulated, so long intervals do not drift.
template <class Attribute>
inline void march_interval(const RayContext& r, float a, float b, Attribute&& attribute,
                           Accum& acc) {
  for (int k = 0;; ++k) {
    const float t0 = a + static_cast<float>(k) * r.step;
    if (!(t0 < b)) break;
    const float t1 = std::min(a + static_cast<float>(k + 1) * r.step, b);
    const float s = 0.5f * (t0 + t1);
    take_sample(r, attribute(s), s, t1 - t0, acc);
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

float light_at(const RayContext& r, LightMethod method, const Candidate* cand, int n,
               float intensity, std::uint32_t& samples) {
  Accum acc;
  if (method == LightMethod::Naive) {
    for (int c = 0; c < n; ++c) {
      const int j = cand[c].primitive;
      march_interval(r, cand[c].t_in, cand[c].t_out, [j](float) { return j; }, acc);
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
        march_interval(r, cand[first].t_in, end, [j](float) { return j; }, acc);
      } else {
        march_interval(
            r, cand[first].t_in, end,
            [&](float s) { return attribute_union(r, cand, first, last, s); }, acc);
      }
    }
  }
  samples = acc.samples;
  return acc.scatter + intensity * acc.transmittance;
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

  const auto start = std::chrono::steady_clock::now();
  // Samples per row of voxels, summed after the loop (no shared counter between threads).
  std::vector<std::uint64_t> row_samples(static_cast<std::size_t>(rz) * ry, 0);
  parallel_chunks(static_cast<std::size_t>(rz) * ry, s.threads, [&](std::size_t b, std::size_t e) {
    // One candidate buffer per chunk, big enough for every primitive: nothing is dropped and
    // nothing is allocated per voxel.
    std::vector<Candidate> cand(static_cast<std::size_t>(capacity));
    for (std::size_t row = b; row < e; ++row) {
      const int z = static_cast<int>(row / ry), y = static_cast<int>(row % ry);
      for (int x = 0; x < rx; ++x) {
        const glm::vec3 v = box.lo + (glm::vec3(x, y, z) + 0.5f) * cell;
        const int n =
            collect_candidates(cloud, v, s.sun_dir, 0.0f, INFINITY, cand.data(), capacity);
        const RayContext r{cloud, density, v, s.sun_dir, s.step, s.extinction, scatter};
        std::uint32_t count = 0;
        const std::size_t idx = row * rx + x;
        light[idx] = light_at(r, s.method, cand.data(), n, s.intensity, count);
        if (samples) samples[idx] = count;
        row_samples[row] += count;
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
