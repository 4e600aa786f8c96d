// The physical lighting mode's shading (RENDER_CONTRACT "Physical lighting"), shared by the C++
// marcher of 2018 clouds and the volume marcher; shaders/common/physical.glsl is its GLSL twin.
//
// A sample at p of extinction σ = extinction_scale·ρ, seen along the unit ray direction d,
// with the light of light/physical.hpp (τ_sun on the sun's lattice, the world lattice's diffuse
// sunlight F and sky light S, both fluences with their gain):
//   S(p) = ϖ·( E_sun·( Σ_{i<octaves} aⁱ·phase(bⁱ·g, d·sun)·Pᵢ(τ_sun(p)) + F(p)/4π ) + S(p)/4π )
//   Pᵢ(τ) = e^{−cⁱ·τ}                       (poisson = 0: Wrenninge et al. 2013's octaves)
//   Pᵢ(τ) = (β·τ)ⁱ/i! · e^{−cⁱ·τ}           (poisson = β > 0: Poisson-weighted octaves)
//   colour += T·(1 − e^{−σΔ})·S(p),  T *= e^{−σΔ}
// (order 0 is single scattering). The Poisson weights give order i the share of light that
// has scattered i times on its way in, after the number of collisions along a path of optical
// depth β·τ: thin fringes draw little high-order light and the cloud's depths most of theirs.
// The first sample of every
// union interval sits at ξ·Δ from its start, ξ the interleaved gradient noise of the pixel
// (Jimenez 2014): ξ = fract(52.9829189·fract(0.06711056·x + 0.00583715·y)) with
// x = column + 5.588238·seed, y = row + 5.588238·seed.
#pragma once

#include <cmath>
#include <vector>

#include <glm/vec3.hpp>

#include "cumuli/light/physical.hpp"
#include "cumuli/light/volume.hpp"
#include "cumuli/phase.hpp"

namespace cumuli {

constexpr int kMaxOctaves = 8;
// The camera ray's step grows (PhysicalParams::coarsen_below) only between blocks of this many
// queued samples (the C++ marcher's batch), so that the GLSL twin takes the same steps.
constexpr int kCoarsenEvery = 16;
constexpr float kMaxCoarsen = 8.0f;
// Entries per order of PhysicalParams::order_phase, at sin(θ/2) = k/(K − 1), θ the scattering
// angle.
constexpr int kOrderPhaseSize = 64;

struct PhysicalParams {
  float extinction_scale = 12.0f;
  float albedo = 0.99f;
  bool dual_hg = false;
  float g1 = 0.6f, g2 = -0.3f, blend = 0.2f;  // blend: weight of the second lobe
  bool mie = false;                           // the approximate Mie phase (phase.hpp) instead
  float droplet_diameter = 20.0f;             // µm; mie_params are its fits
  ApproxMie mie_params = approx_mie_params(20.0f);
  int octaves = 4;  // scattering orders drawn (1: single scattering)
  float oct_a = 0.5f, oct_b = 0.5f, oct_c = 0.5f;
  // The angular distribution of orders i ≥ 1, tabulated: row i − 1 holds order i's phase at
  // sin(θ/2) = k/(kOrderPhaseSize − 1), read with linear interpolation in sin(θ/2) (the table:
  // cumuli.light.phase.order_phase_table, the phase convolved with itself i times). Empty:
  // phase(bⁱ·g) (Wrenninge et al. 2013's octaves). Order 0 is always the phase itself.
  std::vector<float> order_phase;
  float oct_poisson = 0.0f;  // β of the Poisson weights, in [0, 16] (0: plain octaves)
  // Order 0's depth scale: 1 − f·ϖ with f the phase's forward-peak share (the δ-M sun), 1: e^{−τ}.
  float oct_first = 1.0f;
  // The camera ray's optical-depth scale for radiance: 1 − f·ϖ (the δ-M view: the forward peak
  // carries what lies behind on to the camera), 1: e^{−τ}. The coverage (alpha) keeps e^{−τ}.
  float view_scale = 1.0f;
  // The diffuse light's share of the view's emission: 1 − f (the δ-M view: its forward peak
  // scatters the diffuse light on along the ray, not towards the camera anew), 1: all of it.
  float view_diffuse = 1.0f;
  int jitter_seed = 0;
  float min_transmittance = 1e-3f;  // the ray stops below it
  // The camera ray's step doubles each time its view transmittance falls a decade below this
  // (checked every kCoarsenEvery queued samples), up to kMaxCoarsen times the step; 0: never.
  float coarsen_below = 0.0f;

  void validate() const;  // throws std::invalid_argument
  // The phase function with its g's scaled by `scale`.
  float phase(float cos_theta, float scale) const;
  // Order i's phase (i ≥ 1) at cos θ: order_phase's row i − 1, or phase(bⁱ·g) without a table.
  float order_phase_at(int order, float cos_theta, float b_power) const;
};

// The per-ray constants: weight aⁱ·pᵢ(cosθ) (order_phase_at) and depth scale cⁱ of every order.
struct OctaveTerms {
  int n = 1;
  float weight[kMaxOctaves] = {};
  float scale[kMaxOctaves] = {};
  float poisson = 0.0f;  // β
  OctaveTerms(const PhysicalParams& p, float cos_theta);
  // Σ weight_i·Pᵢ(τ): Pᵢ = e^{−scale_i·τ}, times (β·τ)ⁱ/i! when β > 0.
  float sum(float tau) const;
};

// A drawable's physical light as the drawers read it: its lattices held in the vectors, or
// viewed where they lie (set_views: the caller keeps them alive while drawing; a renderer's
// lattices run to tens of MB, which a copy per frame would spend a good part of the frame on).
struct PhysicalGrids {
  SunFrame frame;
  std::vector<float> depth;    // [w][v][u]
  std::vector<float> columns;  // [v][u], or empty: depth upstream of each column, added to depth
  VolumeGrid grid;
  std::vector<float> rgba;  // [z][y][x][4]: F, S.rgb

  void set_views(const float* depth_values, std::size_t depth_count, const float* rgba_values,
                 std::size_t rgba_count) {
    depth_view_ = depth_values;
    depth_count_ = depth_count;
    rgba_view_ = rgba_values;
    rgba_count_ = rgba_count;
  }
  // The per-column map viewed where it lies (set_views first; `count` 0: none).
  void set_columns_view(const float* values, std::size_t count) {
    columns_view_ = values;
    columns_count_ = count;
  }
  const float* depth_data() const { return depth_view_ != nullptr ? depth_view_ : depth.data(); }
  // The per-column map, or nullptr when there is none.
  const float* columns_data() const {
    if (columns_view_ != nullptr) return columns_view_;
    return columns.empty() ? nullptr : columns.data();
  }
  std::size_t columns_size() const {
    return columns_view_ != nullptr ? columns_count_ : columns.size();
  }
  std::size_t depth_size() const { return depth_view_ != nullptr ? depth_count_ : depth.size(); }
  const float* rgba_data() const { return rgba_view_ != nullptr ? rgba_view_ : rgba.data(); }
  std::size_t rgba_size() const { return rgba_view_ != nullptr ? rgba_count_ : rgba.size(); }

  void validate() const;  // throws std::invalid_argument
  // The scattered radiance per unit σt·Δ... : ϖ·(E_sun·(octaves + d·F/4π) + d·S/4π), d the
  // diffuse light's share (PhysicalParams::view_diffuse).
  glm::vec3 source(glm::vec3 p, const OctaveTerms& terms, glm::vec3 sun_irradiance, float albedo,
                   float diffuse = 1.0f) const;

 private:
  const float* depth_view_ = nullptr;
  std::size_t depth_count_ = 0;
  const float* rgba_view_ = nullptr;
  std::size_t rgba_count_ = 0;
  const float* columns_view_ = nullptr;
  std::size_t columns_count_ = 0;
};

// Interleaved gradient noise in [0, 1) of pixel (row, col) for `seed`.
float jitter(int row, int col, int seed);

}  // namespace cumuli
