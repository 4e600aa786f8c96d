// Particle clouds (Harris 2002, "Real-Time Cloud Rendering for Games", §2).
//
// A particle is a roughly spherical blob: centre p_k, splat radius r_k (the screen-aligned quad
// has side 2·r_k), optical depth τ_k of the whole particle and albedo a_k. As a density it is the
// Gaussian σ(x) = β_k·exp(−|x − p_k|²/(2 s_k²)), s_k = r_k/3 (spec §2.2 [decision]), whose
// optical depth through the centre is τ_k = β_k·s_k·√(2π).
//
// The paper gives no generator beyond "filling a volume with particles"; cumuli offers (all
// seeded, bit-identical whatever the thread count: one Rng::stream per particle):
//   * particle_fill: uniform centres in the union of a cloud's ellipsoids (primitive drawn with
//     probability ∝ volume, point uniform in it, accepted with probability 1/(number of
//     primitives containing it), which makes the density uniform over the union), radius uniform
//     in [r_min, r_max], τ constant or modulated by fBm (τ_k = τ·fbm(p_k)/mean over the cloud);
//   * particles_from_volume: importance sampling of a density volume (voxel ∝ density, point
//     uniform in the voxel, τ_k = τ·ρ(voxel)/mean of the sampled ρ).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/model/cloud.hpp"
#include "cumuli/noise.hpp"
#include "cumuli/primitives.hpp"

namespace cumuli {

// Largest particle count of one cloud (spec §12.5).
constexpr std::size_t kMaxParticles = std::size_t{1} << 22;
// Range of a particle's optical depth τ_k (spec §2.1).
constexpr float kMaxParticleTau = 100.0f;

// Read-only view of a particle cloud's arrays (numpy memory from the bindings).
struct ParticleView {
  const float* centres = nullptr;  // n × 3
  const float* radii = nullptr;    // n
  const float* tau = nullptr;      // n
  const float* albedo = nullptr;   // n
  std::size_t n = 0;

  glm::vec3 centre(std::size_t k) const {
    return glm::vec3(centres[3 * k], centres[3 * k + 1], centres[3 * k + 2]);
  }
  // Throws std::invalid_argument naming the array: n in [1, kMaxParticles], finite centres,
  // radii > 0, τ in (0, 100], albedo in [0, 1].
  void validate() const;
};

// Owned particle arrays, what the generators return.
struct ParticleArrays {
  std::vector<float> centres;  // n × 3
  std::vector<float> radii, tau, albedo;

  std::size_t size() const { return radii.size(); }
  ParticleView view() const {
    return {centres.data(), radii.data(), tau.data(), albedo.data(), size()};
  }
};

struct Sphere {
  glm::vec3 centre{0.0f};
  float radius = 0.0f;
};

// AABB of the particles' centres ± radii (float32 min/max).
Box particle_bounds(const ParticleView& particles);
// Bounding sphere: centre = centre of particle_bounds, radius = max_k(|p_k − c| + r_k).
Sphere particle_sphere(const ParticleView& particles);

struct ParticleFillParams {
  int n = 1000;
  float radius_min = 0.0f;  // ≤ 0 together with radius_max ≤ 0: 0.15·r̄ and 0.3·r̄ (r̄ = mean
  float radius_max = 0.0f;  // primitive radius, spec §2.3 [decision])
  float tau = 8.0f;
  float albedo = 0.9f;
  const Noise* noise = nullptr;  // non-null: τ modulated by fBm
  FbmParams fbm;
  float tau_floor = 1e-3f;  // smallest fBm-modulated τ_k (fBm may be 0 somewhere)
  std::uint64_t seed = 0;

  static constexpr int kMaxAttempts = 4096;  // rejection attempts per particle before accepting
  void validate() const;                     // throws std::invalid_argument naming the parameter
};

// Fill the union of `shape`'s ellipsoids with particles (see the header comment).
ParticleArrays particle_fill(const CloudShape& shape, const ParticleFillParams& params,
                             int threads);

struct VolumeSampleParams {
  int n = 1000;
  float radius = 0.0f;  // ≤ 0: (box volume / n)^{1/3}, the mean spacing of n points
  float tau = 8.0f;
  float albedo = 0.9f;
  float tau_floor = 1e-3f;
  std::uint64_t seed = 0;

  void validate() const;
};

// Importance-sample a (d, h, w) density volume [z][y][x] over `box` (voxel (x, y, z) spans
// box.lo + ([x, x+1], [y, y+1], [z, z+1])·(hi − lo)/(w, h, d)). Throws when the density has no
// positive voxel or a negative / non-finite one.
ParticleArrays particles_from_volume(const float* density, int d, int h, int w, const Box& box,
                                     const VolumeSampleParams& params, int threads);

// The particles' Gaussian-blob extinction σ(x) = Σ_k β_k exp(−|x − p_k|²/(2 s_k²)) sampled at
// voxel centres of a (nz, ny, nx) grid over `box` into `out` [z][y][x]. Each blob is summed where
// |x − p_k| ≤ 4 s_k (e^{−8} ≈ 3·10⁻⁴ of its peak is dropped beyond). Voxels sum particles in
// index order, so the result does not depend on the thread count.
void particles_to_volume(const ParticleView& particles, int nx, int ny, int nz, const Box& box,
                         float* out, int threads);

}  // namespace cumuli
