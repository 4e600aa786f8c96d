// A cloud as the core sees it: primitives plus the density model that fills them.
//
// DESIGN §4. Pseudo-spheroid model (eq. 2): at a sample p attributed to primitive j, ρ = fbm(p),
// γ = exp(−|q_j| / ((1 − κ) + 2κρ)); the sample is cloud only if ρ < γ, with density ρ.
// Metaball model (eqs. 19–21): inside where Σ 1/|q_i|² ≥ 1 (Σ r_i²/|p − c_i|² for spheres);
// density ρ = fbm(p) · r̄² · φ with r̄² the mean squared radius.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "cumuli/noise.hpp"
#include "cumuli/primitives.hpp"

namespace cumuli {

enum class DensityModel { Spheroid, Metaball };

struct DensityParams {
  DensityModel model = DensityModel::Spheroid;
  float kappa = 0.5f;    // κ of eq. (2), in [0, 1]
  float phi = 0.6f;      // φ of eq. (21)
  float mean_r2 = 1.0f;  // r̄² of eq. (20), computed once from the primitives
};

struct CloudShape {
  std::vector<Ellipsoid> primitives;
  DensityParams density;
  // Where the cloud's fBm is read: at p − noise_offset. Zero for a cloud whose noise is the
  // world's (the paper's); a cloud moved by the wind carries its noise along (wind · time), so
  // that it is the same medium wherever the wind takes it.
  glm::vec3 noise_offset{0.0f};

  Box bounds() const;                 // union of the primitives' bounds
  glm::vec3 centre() const;           // centre of the bounds
  float mean_squared_radius() const;  // eq. (20), with an ellipsoid's r² the mean of its radii²
  void validate() const;              // throws std::invalid_argument (empty, NaN, radii ≤ 0, ...)
};

// Where density comes from: fBm of a noise lattice, or (for analytic tests) a constant.
struct DensitySource {
  const Noise* noise = nullptr;
  FbmParams fbm;
  float constant = -1.0f;  // ≥ 0: use this instead of fBm
  // When set, counts the fBm evaluations (the marcher's work statistics; one counter per thread).
  std::uint64_t* evaluations = nullptr;

  float operator()(glm::vec3 p) const {
    if (constant >= 0.0f) return constant;
    if (evaluations != nullptr) ++*evaluations;
    return noise->fbm(p, fbm);
  }
  // operator() at `count` points (xyz interleaved) into `out`, bit-identical to calling it on
  // each: the noise's bulk (SIMD) fBm, on the calling thread (the callers thread over rows or
  // columns already).
  void many(const float* points, std::size_t count, float* out) const;
};

// The points at which a cloud's fBm is read, for `count` points (xyz interleaved): `points`
// itself when the cloud carries no noise offset, else a per-thread copy moved by −noise_offset
// (valid until the next call on the same thread).
const float* noise_points(const CloudShape& cloud, const float* points, std::size_t count);

// One density sample. `gamma` is eq. (2)'s γ (1 for metaballs), used by the render pass.
struct DensitySample {
  float rho = 0.0f;
  float gamma = 0.0f;
};

// Eq. (2) at a sample whose normalised distance to its primitive is q ≤ 1 and whose fBm is rho:
// spheroid_density once both are known (the bulk paths evaluate the fBm of many points at once).
DensitySample spheroid_density_given(float kappa, float q, float rho);
// Whether p lies inside the metaball iso-surface Σ 1/|q_i|² ≥ 1 (eq. 19).
bool metaball_inside(const CloudShape& cloud, glm::vec3 p);
// Eq. (20)–(21)'s density of a point inside the iso-surface whose fBm is `fbm`.
inline float metaball_rho(const CloudShape& cloud, float fbm) {
  return fbm * cloud.density.mean_r2 * cloud.density.phi;
}

// Pseudo-spheroid density at p attributed to primitive j (eq. 2); rho = 0 outside the cloud.
DensitySample spheroid_density(const CloudShape& cloud, int j, glm::vec3 p,
                               const DensitySource& src);
// Metaball density at p (eqs. 19–21); rho = 0 outside the iso-surface.
DensitySample metaball_density(const CloudShape& cloud, glm::vec3 p, const DensitySource& src);
// Dispatch on cloud.density.model (j is ignored by the metaball model).
DensitySample cloud_density(const CloudShape& cloud, int j, glm::vec3 p, const DensitySource& src);

// The cloud's density FIELD at p (the physical mode's medium, RENDER_CONTRACT "Physical
// lighting"): a spheroid sample belongs to the primitive p is deepest inside (smallest |q|, the
// first on ties) — the union march's attribution rule; metaballs as cloud_density.
DensitySample field_density(const CloudShape& cloud, glm::vec3 p, const DensitySource& src);

// The density field on a res[0] × res[1] × res[2] (x, y, z) lattice over `box`, [z][y][x]:
// each voxel the mean of field_density at ss³ points, (i + (a + ½)/ss)·(hi − lo)/res + lo for
// a = 0..ss−1 on each axis (ss = 1: the texel centre). Threads over z-slices; the result does
// not depend on the thread count. ss must be in [1, 8] (std::invalid_argument).
std::vector<float> density_grid(const CloudShape& cloud, const DensitySource& src, const Box& box,
                                const int res[3], int ss, int threads);

}  // namespace cumuli
