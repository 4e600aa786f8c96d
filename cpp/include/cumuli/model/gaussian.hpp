// 3D Gaussian cumulus (Jiménez de Parga & Gómez Palomo 2018, §3.6.1, Table 2, eqs. 15–17).
//
// N sphere centres at C + 𝒩(μ, σ) per axis, each offset clamped per Table 2; a radius per sphere
// from eq. (15), eq. (16) or a uniform range (the metaball preset of Fig. 13); then the hollow
// filter (drop spheres whose offset from C lies inside the box (3σx/4, σy/3, 3σz/4)) and the
// containment filter of eq. (17) (drop spheres that lie entirely inside another).
//
// Choices where the paper is ambiguous (each one is a parameter):
// * Clamps are in units of σ about μ: axis k's offset lies in [μk + lo_k·σk, μk + hi_k·σk]. With
//   μ = 0 this is Table 2 exactly ([−k₁σx, k₂σx], [μy, tσy] with lo_y = 0, [−m₁σz, m₂σz]).
// * "Clamped" saturates by default (a draw below the base sits on the base). That is what makes the
//   flat base and is what reproduces the paper's "~20 %" hollow share: saturating puts half the
//   draws on y = μy, inside the hollow box's y range. ClampMode::Resample redraws instead (a
//   truncated normal), which removes only ~9 %.
// * Eq. (16) as printed multiplies the three squared terms under the root; the authors'
//   implementation sums them (an ellipsoidal distance, so the radius falls off with the distance
//   to C in every direction). Eq16Combine::Sum is the default; Product is the printed formula.
// * Eq. (15) uses |Px| + |Pz| with P taken relative to C (otherwise the radius would depend on
//   where the cloud is placed in the world).
// * The final radius is radius_scale × (formula), so ε is the formula's maximum before scaling.
// * Containment (eq. 17) compares spheres (equal radii); when two spheres coincide exactly the one
//   drawn first is kept.
#pragma once

#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

namespace cumuli {

enum class RadiusModel { Eq15, Eq16, Uniform };
enum class Eq16Combine { Sum, Product };
enum class ClampMode { Saturate, Resample };

struct GaussianCumulusParams {
  glm::vec3 centre{0.0f};
  int n = 35;
  glm::vec3 mu{0.0f};
  glm::vec3 sigma{3.8f, 1.7f, 3.7f};
  glm::vec3 clamp_lo{-2.0f, 0.0f, -2.0f};  // in units of σ about μ
  glm::vec3 clamp_hi{2.0f, 2.0f, 2.0f};
  ClampMode clamp_mode = ClampMode::Saturate;
  RadiusModel radius_model = RadiusModel::Eq16;
  Eq16Combine eq16_combine = Eq16Combine::Sum;
  float epsilon = 2.5f;       // ε₁ (eq. 15, paper 15) or ε₂ (eq. 16, paper 2.5)
  float radius_scale = 2.9f;  // multiplies the formula's radius
  float radius_lo = 1.0f;     // RadiusModel::Uniform: radius ∈ [lo, hi] (before radius_scale)
  float radius_hi = 1.0f;
  bool hollow = true;
  glm::vec3 hollow_box{0.75f, 1.0f / 3.0f, 0.75f};  // half extents in units of σ
  bool remove_contained = true;
  std::uint64_t seed = 0;

  static constexpr int kMaxPrimitives = 10000;  // the containment filter is O(n²)
  void validate() const;  // throws std::invalid_argument naming the bad parameter
};

struct GaussianCumulusResult {
  std::vector<glm::vec3> centres;  // kept spheres, in the order they were drawn
  std::vector<float> radii;
  // What each step did.
  int drawn = 0;
  int clamped = 0;  // coordinates that hit a clamp (Saturate) or were redrawn
  int removed_by_hollow = 0;
  int removed_by_containment = 0;
};

// The hollow filter's test: is `offset` (sphere centre − C) strictly inside the box of half
// extents `half`?
bool in_hollow_box(glm::vec3 offset, glm::vec3 half);

// Eq. (17): indices (into centres/radii) of the spheres to keep so that no kept sphere lies
// inside another kept sphere. Containers are visited first (by radius, largest first), so the
// result does not depend on the order of containment chains.
std::vector<int> remove_contained_spheres(const std::vector<glm::vec3>& centres,
                                          const std::vector<float>& radii);

GaussianCumulusResult gaussian_cumulus(const GaussianCumulusParams& params);

}  // namespace cumuli
