#include "cumuli/model/particles.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <glm/geometric.hpp>

#include "cumuli/parallel.hpp"
#include "cumuli/rng.hpp"

namespace cumuli {

namespace {

bool finite3(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// τ_k = τ·v_k/mean(v), floored at tau_floor and capped at kMaxParticleTau; constant τ when every
// v_k is 0. The mean is a double sum in index order (deterministic).
void modulate_tau(std::vector<float>& tau, const std::vector<float>& values, float base,
                  float floor_value) {
  double sum = 0.0;
  for (const float v : values) sum += v;
  const double mean = values.empty() ? 0.0 : sum / static_cast<double>(values.size());
  for (std::size_t k = 0; k < tau.size(); ++k) {
    if (!(mean > 0.0)) {
      tau[k] = base;
      continue;
    }
    const float t = static_cast<float>(static_cast<double>(base) * values[k] / mean);
    tau[k] = std::min(kMaxParticleTau, std::max(floor_value, t));
  }
}

}  // namespace

void ParticleView::validate() const {
  if (n < 1 || n > kMaxParticles)
    throw std::invalid_argument("a particle cloud holds 1 to " + std::to_string(kMaxParticles) +
                                " particles, got " + std::to_string(n));
  for (std::size_t k = 0; k < n; ++k) {
    if (!finite3(centre(k))) throw std::invalid_argument("centres must be finite");
    if (!std::isfinite(radii[k]) || !(radii[k] > 0.0f))
      throw std::invalid_argument("radii must be finite and positive");
    if (!std::isfinite(tau[k]) || !(tau[k] > 0.0f) || tau[k] > kMaxParticleTau)
      throw std::invalid_argument("tau must be in (0, 100]");
    if (!std::isfinite(albedo[k]) || albedo[k] < 0.0f || albedo[k] > 1.0f)
      throw std::invalid_argument("albedo must be in [0, 1]");
  }
}

Box particle_bounds(const ParticleView& particles) {
  Box b;
  for (std::size_t k = 0; k < particles.n; ++k) {
    const glm::vec3 p = particles.centre(k);
    const glm::vec3 r(particles.radii[k]);
    const glm::vec3 lo = p - r, hi = p + r;
    if (k == 0) {
      b.lo = lo;
      b.hi = hi;
    } else {
      b.lo = glm::min(b.lo, lo);
      b.hi = glm::max(b.hi, hi);
    }
  }
  return b;
}

Sphere particle_sphere(const ParticleView& particles) {
  const Box b = particle_bounds(particles);
  Sphere s;
  s.centre = (b.lo + b.hi) * 0.5f;
  for (std::size_t k = 0; k < particles.n; ++k) {
    const float reach = glm::length(particles.centre(k) - s.centre) + particles.radii[k];
    s.radius = std::max(s.radius, reach);
  }
  return s;
}

void ParticleFillParams::validate() const {
  if (n < 1 || static_cast<std::size_t>(n) > kMaxParticles)
    throw std::invalid_argument("n must be in [1, " + std::to_string(kMaxParticles) + "], got " +
                                std::to_string(n));
  const bool automatic = radius_min <= 0.0f && radius_max <= 0.0f;
  if (!automatic && (!std::isfinite(radius_min) || !std::isfinite(radius_max) ||
                     !(radius_min > 0.0f) || radius_max < radius_min))
    throw std::invalid_argument("radius must be (rmin, rmax) with 0 < rmin <= rmax");
  if (!std::isfinite(tau) || !(tau > 0.0f) || tau > kMaxParticleTau)
    throw std::invalid_argument("tau must be in (0, 100]");
  if (!std::isfinite(albedo) || albedo < 0.0f || albedo > 1.0f)
    throw std::invalid_argument("albedo must be in [0, 1]");
  if (!std::isfinite(tau_floor) || !(tau_floor > 0.0f) || tau_floor > tau)
    throw std::invalid_argument("tau_floor must be in (0, tau]");
  if (noise != nullptr) fbm.validate();
}

ParticleArrays particle_fill(const CloudShape& shape, const ParticleFillParams& params,
                             int threads) {
  params.validate();
  shape.validate();
  const std::size_t m = shape.primitives.size();
  // Primitive choice ∝ volume (r_x·r_y·r_z; the 4π/3 cancels), as a cumulative table.
  std::vector<double> cumulative(m);
  double total = 0.0, radius_sum = 0.0;
  for (std::size_t j = 0; j < m; ++j) {
    const glm::vec3 r = shape.primitives[j].radii;
    total += static_cast<double>(r.x) * r.y * r.z;
    cumulative[j] = total;
    radius_sum += (static_cast<double>(r.x) + r.y + r.z) / 3.0;
  }
  if (!(total > 0.0) || !std::isfinite(total))
    throw std::invalid_argument("cloud primitives have no volume");
  float rmin = params.radius_min, rmax = params.radius_max;
  if (rmin <= 0.0f && rmax <= 0.0f) {
    const double mean_r = radius_sum / static_cast<double>(m);
    rmin = static_cast<float>(0.15 * mean_r);
    rmax = static_cast<float>(0.3 * mean_r);
  }
  const std::size_t n = static_cast<std::size_t>(params.n);
  ParticleArrays out;
  out.centres.resize(3 * n);
  out.radii.resize(n);
  out.tau.assign(n, params.tau);
  out.albedo.assign(n, params.albedo);
  parallel_chunks(n, threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k) {
      Rng rng = Rng::stream(params.seed, k);
      glm::vec3 p(0.0f);
      for (int attempt = 0; attempt < ParticleFillParams::kMaxAttempts; ++attempt) {
        const double u = rng.uniform_double() * total;
        const std::size_t j = std::min<std::size_t>(
            m - 1,
            static_cast<std::size_t>(std::upper_bound(cumulative.begin(), cumulative.end(), u) -
                                     cumulative.begin()));
        glm::vec3 q;
        do {  // uniform in the unit ball (rejection from the cube)
          q = glm::vec3(2.0f * rng.uniform() - 1.0f, 2.0f * rng.uniform() - 1.0f,
                        2.0f * rng.uniform() - 1.0f);
        } while (glm::dot(q, q) > 1.0f);
        const Ellipsoid& e = shape.primitives[j];
        p = e.centre + e.rotation * (e.radii * q);
        // Accept with probability 1/(primitives containing p): uniform over the union.
        int count = 0;
        for (const Ellipsoid& other : shape.primitives)
          if (glm::dot(other.to_local(p), other.to_local(p)) <= 1.0f) ++count;
        if (count <= 1 || rng.uniform_double() * count < 1.0) break;
      }
      out.centres[3 * k] = p.x;
      out.centres[3 * k + 1] = p.y;
      out.centres[3 * k + 2] = p.z;
      out.radii[k] = rmin + (rmax - rmin) * rng.uniform();
    }
  });
  if (params.noise != nullptr) {
    std::vector<float> values(n);
    params.noise->fbm_many(noise_points(shape, out.centres.data(), n), n, values.data(), params.fbm,
                           threads);
    modulate_tau(out.tau, values, params.tau, params.tau_floor);
  }
  return out;
}

void VolumeSampleParams::validate() const {
  if (n < 1 || static_cast<std::size_t>(n) > kMaxParticles)
    throw std::invalid_argument("n must be in [1, " + std::to_string(kMaxParticles) + "], got " +
                                std::to_string(n));
  if (!std::isfinite(radius) || radius < 0.0f)
    throw std::invalid_argument("radius must be a finite number >= 0 (0: automatic)");
  if (!std::isfinite(tau) || !(tau > 0.0f) || tau > kMaxParticleTau)
    throw std::invalid_argument("tau must be in (0, 100]");
  if (!std::isfinite(albedo) || albedo < 0.0f || albedo > 1.0f)
    throw std::invalid_argument("albedo must be in [0, 1]");
  if (!std::isfinite(tau_floor) || !(tau_floor > 0.0f) || tau_floor > tau)
    throw std::invalid_argument("tau_floor must be in (0, tau]");
}

ParticleArrays particles_from_volume(const float* density, int d, int h, int w, const Box& box,
                                     const VolumeSampleParams& params, int threads) {
  params.validate();
  if (d < 1 || h < 1 || w < 1) throw std::invalid_argument("density must be a non-empty volume");
  if (!finite3(box.lo) || !finite3(box.hi) || !(box.hi.x > box.lo.x) || !(box.hi.y > box.lo.y) ||
      !(box.hi.z > box.lo.z))
    throw std::invalid_argument("box must be finite with hi > lo on every axis");
  const std::size_t voxels = static_cast<std::size_t>(d) * h * w;
  std::vector<double> cumulative(voxels);
  double total = 0.0;
  for (std::size_t v = 0; v < voxels; ++v) {
    const float rho = density[v];
    if (!std::isfinite(rho) || rho < 0.0f)
      throw std::invalid_argument("density must be finite and non-negative");
    total += rho;
    cumulative[v] = total;
  }
  if (!(total > 0.0)) throw std::invalid_argument("density has no positive voxel");
  const glm::vec3 size = box.hi - box.lo;
  const glm::vec3 cell =
      size / glm::vec3(static_cast<float>(w), static_cast<float>(h), static_cast<float>(d));
  float radius = params.radius;
  if (radius <= 0.0f)
    radius = static_cast<float>(
        std::cbrt(static_cast<double>(size.x) * size.y * size.z / static_cast<double>(params.n)));
  const std::size_t n = static_cast<std::size_t>(params.n);
  ParticleArrays out;
  out.centres.resize(3 * n);
  out.radii.assign(n, radius);
  out.tau.assign(n, params.tau);
  out.albedo.assign(n, params.albedo);
  std::vector<float> rho(n);
  parallel_chunks(n, threads, [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k) {
      Rng rng = Rng::stream(params.seed, k);
      const double u = rng.uniform_double() * total;
      std::size_t v = static_cast<std::size_t>(
          std::upper_bound(cumulative.begin(), cumulative.end(), u) - cumulative.begin());
      v = std::min(v, voxels - 1);
      while (density[v] <= 0.0f && v + 1 < voxels) ++v;  // u landed on a zero-width step
      const std::size_t x = v % static_cast<std::size_t>(w);
      const std::size_t y = (v / static_cast<std::size_t>(w)) % static_cast<std::size_t>(h);
      const std::size_t z = v / (static_cast<std::size_t>(w) * static_cast<std::size_t>(h));
      const glm::vec3 jitter(rng.uniform(), rng.uniform(), rng.uniform());
      const glm::vec3 p =
          box.lo + (glm::vec3(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)) +
                    jitter) *
                       cell;
      out.centres[3 * k] = p.x;
      out.centres[3 * k + 1] = p.y;
      out.centres[3 * k + 2] = p.z;
      rho[k] = density[v];
    }
  });
  modulate_tau(out.tau, rho, params.tau, params.tau_floor);
  return out;
}

void particles_to_volume(const ParticleView& particles, int nx, int ny, int nz, const Box& box,
                         float* out, int threads) {
  const glm::vec3 cell =
      (box.hi - box.lo) /
      glm::vec3(static_cast<float>(nx), static_cast<float>(ny), static_cast<float>(nz));
  constexpr float kSqrtTwoPi = 2.5066282746310002f;
  const std::size_t slice = static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny);
  parallel_chunks(static_cast<std::size_t>(nz), threads, [&](std::size_t z0, std::size_t z1) {
    for (std::size_t z = z0; z < z1; ++z) std::fill(out + z * slice, out + (z + 1) * slice, 0.0f);
    for (std::size_t k = 0; k < particles.n; ++k) {
      const glm::vec3 p = particles.centre(k);
      const float s = particles.radii[k] / 3.0f;
      const float beta = particles.tau[k] / (s * kSqrtTwoPi);
      const float reach = 4.0f * s;
      const float inv2s2 = 1.0f / (2.0f * s * s);
      // Voxel index range whose centres can lie within `reach` of p, per axis.
      int lo[3], hi[3];
      const int dims[3] = {nx, ny, nz};
      for (int a = 0; a < 3; ++a) {
        const float f0 = (p[a] - reach - box.lo[a]) / cell[a] - 0.5f;
        const float f1 = (p[a] + reach - box.lo[a]) / cell[a] - 0.5f;
        // Clamped in float before the conversion (a far particle must not overflow an int).
        lo[a] = static_cast<int>(std::clamp(std::ceil(f0), 0.0f, static_cast<float>(dims[a])));
        hi[a] =
            static_cast<int>(std::clamp(std::floor(f1), -1.0f, static_cast<float>(dims[a] - 1)));
      }
      const int zlo = std::max(lo[2], static_cast<int>(z0));
      const int zhi = std::min(hi[2], static_cast<int>(z1) - 1);
      for (int z = zlo; z <= zhi; ++z)
        for (int y = lo[1]; y <= hi[1]; ++y)
          for (int x = lo[0]; x <= hi[0]; ++x) {
            const glm::vec3 c = box.lo + (glm::vec3(static_cast<float>(x), static_cast<float>(y),
                                                    static_cast<float>(z)) +
                                          0.5f) *
                                             cell;
            const glm::vec3 dv = c - p;
            const float r2 = glm::dot(dv, dv);
            if (r2 > reach * reach) continue;
            out[static_cast<std::size_t>(z) * slice + static_cast<std::size_t>(y) * nx + x] +=
                beta * std::exp(-r2 * inv2s2);
          }
    }
  });
}

}  // namespace cumuli
